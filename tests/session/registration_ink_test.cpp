// Registration of a still scene whose ink and marker change contrast from one
// capture to the other (issue 37 item 4). ECC alone on every pixel (tile
// consensus off) is pulled by whole pixels. With the tile consensus
// (RegistrationOptions::tile_consensus, the default) the tiles decide: each tile's own
// translation, the disagreeing ones left out, so a still subject keeps the
// identity and a known sub-pixel motion is found as on skin alone. The
// opt-in robust round (exclude_photometric_outliers, without the tiles)
// leaves the ink and marker out instead. Skin: the smooth blotches of registration_test.cpp with
// camera noise; the ink disc and the marker stroke darken it by their own
// factor in each capture (one illuminant to another), the moving capture at
// another gain as well.
#include "chromo/session/registration.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <random>

namespace chromo::session::ink_test {
namespace {

constexpr int kWidth = 224, kHeight = 160;

double skin(double x, double y) {
  double v = 0.4;
  for (int k = 0; k < 14; ++k) {
    const double cx = 20 + (37 * k) % 190, cy = 15 + (53 * k) % 130, r = 6 + 3 * (k % 4);
    v += 0.08 * ((k % 2) ? 1 : -1) * std::exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (2 * r * r));
  }
  return v + 0.02 * std::sin(x / 7.0) * std::cos(y / 9.0) + 0.015 * std::sin(x / 2.3 + y / 3.1) * std::cos(y / 2.7 - x / 4.1);
}

// Share of the point's pixel covered by a region (4 × 4 subsamples): the ink
// disc, the marker stroke.
double coverage(double x, double y, bool marker) {
  int inside = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      const double u = x - 0.375 + 0.25 * i, v = y - 0.375 + 0.25 * j;
      inside += marker ? std::abs(v - (0.35 * u + 40)) < 4 : std::hypot(u - 150, v - 70) < 18;
    }
  return inside / 16.0;
}

// One capture of the scene moved by (tx, ty): skin × the ink's and the
// marker's factors in this capture, × gain, + noise.
std::vector<float> capture(double ink_factor, double marker_factor, double gain, double tx, double ty, unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0, 0.002);
  std::vector<float> img(kWidth * kHeight);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double u = x + tx, v = y + ty;
      const double ink = coverage(u, v, false), marker = coverage(u, v, true);
      const double factor = (1 - ink + ink * ink_factor) * (1 - marker + marker * marker_factor);
      img[y * kWidth + x] = static_cast<float>(gain * skin(u, v) * factor + noise(random));
    }
  return img;
}

// The reference under one illuminant: ink at 0.25 of skin, marker at 0.5;
// under the other the ink at 0.8 and the marker at 1.3 (it reflects more than skin there).
std::vector<float> reference_capture() { return capture(0.25, 0.5, 1.0, 0, 0, 1); }
std::vector<float> other_capture(double tx, double ty) { return capture(0.8, 1.3, 0.7, tx, ty, 2); }

RegistrationOptions ecc_alone() {
  RegistrationOptions options;
  options.tile_consensus = false;
  return options;
}

RegistrationOptions tiles() {
  RegistrationOptions options;
  options.tile_consensus = true;
  return options;
}

RegistrationOptions robust() {
  RegistrationOptions options = ecc_alone();
  options.exclude_photometric_outliers = true;
  return options;
}

// Largest distance between where the registration sends an image corner and where it truly is (moved by t).
double corner_error_px(const RegistrationResult& r, double tx, double ty) {
  double largest = 0;
  for (double x : {0.0, kWidth - 1.0})
    for (double y : {0.0, kHeight - 1.0})
      largest = std::max(largest, std::hypot(r.warp[0][0] * x + r.warp[0][1] * y + r.warp[0][2] - (x - tx),
                                             r.warp[1][0] * x + r.warp[1][1] * y + r.warp[1][2] - (y - ty)));
  return largest;
}

TEST(RegistrationInk, AStillSceneWhoseInkChangesContrastKeepsTheIdentity) {
  const std::vector<float> reference = reference_capture(), still = other_capture(0, 0);
  const RegistrationResult alone = register_channel(reference, still, kWidth, kHeight, ecc_alone());
  const RegistrationResult r = register_channel(reference, still, kWidth, kHeight, tiles());
  const RegistrationResult rr = register_channel(reference, still, kWidth, kHeight, robust());
  const double motion_alone = corner_displacement_px(alone, kWidth, kHeight), motion = corner_displacement_px(r, kWidth, kHeight),
               motion_robust = corner_displacement_px(rr, kWidth, kHeight);
  std::printf("still: ECC alone %.3f px (noise %.4f); tiles %.3f px (noise %.4f, %d of %d tiles kept); robust round %.3f px "
              "(noise %.4f, %.1f%% left out)\n", motion_alone, alone.motion_noise_px, motion, r.motion_noise_px, r.tiles_kept,
              r.tiles_measured, motion_robust, rr.motion_noise_px, 100 * rr.photometric_outlier_share);
  EXPECT_TRUE(motion_is_significant(alone, motion_alone));  // the pull
  EXPECT_EQ(alone.photometric_outlier_share, 0.0);
  EXPECT_EQ(alone.tiles_measured, 0);
  // With the tiles: their motion is not significant, not warped.
  EXPECT_FALSE(motion_is_significant(r, motion));
  EXPECT_LT(motion, kWarpThresholdPx);
  EXPECT_EQ(r.method, RegistrationMethod::kTiles);
  EXPECT_GE(r.tiles_measured, 8);
  EXPECT_GE(2 * r.tiles_kept, r.tiles_measured);  // the tiles on the disc's and the stroke's edges left out
  EXPECT_LT(r.tiles_kept, r.tiles_measured);
  // The robust round leaves ink and marker out instead.
  EXPECT_FALSE(motion_is_significant(rr, motion_robust));
  EXPECT_LT(motion_robust, kWarpThresholdPx);
  EXPECT_GT(rr.photometric_outlier_share, 0.05);  // the disc and the stroke (8% of the frame), with their margin
  EXPECT_LT(rr.photometric_outlier_share, 0.4);
}

TEST(RegistrationInk, AKnownSubPixelMotionIsFoundDespiteTheInk) {
  const std::vector<float> reference = reference_capture(), moved = other_capture(0.32, 0.24);  // 0.4 px
  const RegistrationResult alone = register_channel(reference, moved, kWidth, kHeight, ecc_alone());
  const RegistrationResult r = register_channel(reference, moved, kWidth, kHeight, tiles());
  std::printf("moved 0.4 px: ECC alone corner error %.3f px; tiles (%s) shift (%.3f, %.3f) px, rotation %.4f°, corner "
              "error %.3f px, noise %.4f px\n", corner_error_px(alone, 0.32, 0.24), registration_method_name(r.method),
              r.shift_x_px, r.shift_y_px, r.rotation_deg, corner_error_px(r, 0.32, 0.24), r.motion_noise_px);
  EXPECT_GT(corner_error_px(alone, 0.32, 0.24), 1.0);
  EXPECT_TRUE(motion_is_significant(r, corner_displacement_px(r, kWidth, kHeight)));
  EXPECT_LT(corner_error_px(r, 0.32, 0.24), 0.15);
  // The sub-pixel warp leaves every finite pixel finite (the frame's edge replicated).
  const std::vector<float> warped = warp_channel(moved, kWidth, kHeight, r);
  std::size_t non_finite = 0;
  for (float v : warped) non_finite += !std::isfinite(v);
  EXPECT_EQ(non_finite, 0u);
}

// The robust round's own accuracy on the known motion (opt-in, ECC without the tiles).
TEST(RegistrationInk, TheRobustRoundFindsAKnownSubPixelMotion) {
  const RegistrationResult r = register_channel(reference_capture(), other_capture(0.32, 0.24), kWidth, kHeight, robust());
  std::printf("moved 0.4 px: robust round corner error %.3f px, %.1f%% left out\n", corner_error_px(r, 0.32, 0.24),
              100 * r.photometric_outlier_share);
  EXPECT_LT(corner_error_px(r, 0.32, 0.24), 0.15);
}

}  // namespace
}  // namespace chromo::session::ink_test
