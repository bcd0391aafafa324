#include "chromo/session/registration.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace chromo::session {
namespace {

// A smooth textured scene (skin-like blotches), sampled at any point.
double scene(double x, double y) {
  double v = 0.4;
  for (int k = 0; k < 12; ++k) {
    const double cx = 20 + (37 * k) % 160, cy = 15 + (53 * k) % 120, r = 6 + 3 * (k % 4);
    v += 0.08 * ((k % 2) ? 1 : -1) * std::exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (2 * r * r));
  }
  return v + 0.02 * std::sin(x / 7.0) * std::cos(y / 9.0);
}

constexpr int kWidth = 192, kHeight = 144;

std::vector<float> render(double angle_deg, double tx, double ty) {
  // moving(p) = scene(M p), M = rotation about the image centre + shift.
  const double a = angle_deg * M_PI / 180, c = std::cos(a), s = std::sin(a);
  const double cx = kWidth / 2.0, cy = kHeight / 2.0;
  std::vector<float> img(kWidth * kHeight);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double dx = x - cx, dy = y - cy;
      img[y * kWidth + x] = static_cast<float>(scene(cx + c * dx - s * dy + tx, cy + s * dx + c * dy + ty));
    }
  return img;
}

TEST(Registration, RecoversAKnownShiftAndRotation) {
  const std::vector<float> reference = render(0, 0, 0);
  const std::vector<float> moving = render(1.5, 4.3, -2.7);
  const RegistrationResult r = register_channel(reference, moving, kWidth, kHeight);
  // moving(W x) = scene(M W x) = reference(x) ⇒ W = M⁻¹: rotation −1.5°.
  EXPECT_NEAR(r.rotation_deg, -1.5, 0.05);
  EXPECT_LT(r.residual_motion_px, 0.2);  // at the corners; bilinear resampling leaves ~0.1 px
  EXPECT_GT(r.correlation, 0.95);  // content enters at the borders
  // The warped image matches the reference away from the borders.
  const std::vector<float> warped = warp_channel(moving, kWidth, kHeight, r);
  double worst = 0;
  for (int y = 20; y < kHeight - 20; ++y)
    for (int x = 20; x < kWidth - 20; ++x)
      worst = std::max(worst, std::abs(double(warped[y * kWidth + x]) - reference[y * kWidth + x]));
  EXPECT_LT(worst, 0.004);
  // The displacement W gives the image centre undoes the shift (4.3, −2.7).
  const double cx = kWidth / 2.0, cy = kHeight / 2.0;
  const double wx = r.warp[0][0] * cx + r.warp[0][1] * cy + r.warp[0][2] - cx;
  const double wy = r.warp[1][0] * cx + r.warp[1][1] * cy + r.warp[1][2] - cy;
  const double a = 1.5 * M_PI / 180;
  // M⁻¹ applied to the centre: −R⁻¹ t.
  EXPECT_NEAR(wx, -(std::cos(a) * 4.3 + std::sin(a) * -2.7), 0.05);
  EXPECT_NEAR(wy, -(-std::sin(a) * 4.3 + std::cos(a) * -2.7), 0.05);
}

TEST(Registration, ReportsWhatIsWrongInsteadOfGuessing) {
  const std::vector<float> flat(kWidth * kHeight, 0.5f);
  EXPECT_THROW(register_channel(flat, flat, kWidth, kHeight), RegistrationError);
  EXPECT_THROW(register_channel(flat, flat, kWidth + 1, kHeight), RegistrationError);
}

}  // namespace
}  // namespace chromo::session
