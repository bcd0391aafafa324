// Subsurface spread in the virtual lab's skin scene (issue 37): each
// wavelength blurred by σ(λ), wider in the red; the highlight and the white
// target left alone; the light conserved; off by default.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "chromo/simulators/scene/scene.hpp"
#include "chromo/simulators/scene/subsurface_spread.hpp"
#include "chromo/spectral/grid.hpp"

namespace chromo::simulators {
namespace {

SkinSceneOptions options_128(bool spread) {
  SkinSceneOptions o;
  o.width = o.height = 128;
  o.threads = 2;
  o.subsurface.on = spread;
  return o;
}

int band_of(double nm) { return static_cast<int>(std::lround((nm - spectral::kGridStartNm) / spectral::kGridStepNm)); }

// Σ of squared differences between horizontal neighbours on the skin side
// (the scene's fine detail at one wavelength), and the band's mean there.
struct Detail {
  double energy = 0, mean = 0;
};
Detail detail(const Scene& scene, int band) {
  Detail d;
  std::size_t n = 0;
  const int white = static_cast<int>(SceneRegion::kWhiteTarget);
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x + 1 < scene.width(); ++x) {
      if (scene.regions().at<std::uint8_t>(y, x) == white || scene.regions().at<std::uint8_t>(y, x + 1) == white) continue;
      const double a = scene.albedo_at(x, y)[band], b = scene.albedo_at(x + 1, y)[band];
      d.energy += (b - a) * (b - a), d.mean += a, ++n;
    }
  d.mean /= n;
  return d;
}

TEST(SubsurfaceSpread, RedSpreadsWiderThanBlueAndTheLightIsKept) {
  const Scene sharp = make_skin_scene(options_128(false)), spread = make_skin_scene(options_128(true));
  const int blue = band_of(450), red = band_of(700);
  const Detail sharp_blue = detail(sharp, blue), spread_blue = detail(spread, blue);
  const Detail sharp_red = detail(sharp, red), spread_red = detail(spread, red);
  const double kept_blue = spread_blue.energy / sharp_blue.energy, kept_red = spread_red.energy / sharp_red.energy;
  std::printf("fine detail kept: 450 nm %.3f, 700 nm %.3f\n", kept_blue, kept_red);
  // σ 0.5 px keeps most of the blue's edges, σ 3 px little of the red's.
  EXPECT_GT(kept_blue, 0.4);
  EXPECT_LT(kept_red, 0.25);
  EXPECT_LT(kept_red, 0.5 * kept_blue);
  // Redistributed, not lost: each band's mean over the skin side within 1%.
  EXPECT_NEAR(spread_blue.mean / sharp_blue.mean, 1.0, 0.01);
  EXPECT_NEAR(spread_red.mean / sharp_red.mean, 1.0, 0.01);
  // The white target is neither spread nor lit by the skin.
  for (int y = 0; y < 128; y += 7)
    for (int x = 0; x < 128; ++x)
      if (sharp.regions().at<std::uint8_t>(y, x) == static_cast<int>(SceneRegion::kWhiteTarget))
        ASSERT_EQ(sharp.albedo_at(x, y)[red], spread.albedo_at(x, y)[red]) << x << "," << y;
  // The highlight leaves at the surface: at its centre (0.65 w, 0.2 h) the
  // added flat reflection (0.3) stays on top of the spread skin in every band.
  const int hx = static_cast<int>(0.65 * 128), hy = static_cast<int>(0.2 * 128);
  const double surface = skin_scene_surface_highlight(options_128(true), hx, hy);
  ASSERT_GT(surface, 0.25);
  EXPECT_GT(spread.albedo_at(hx, hy)[blue], surface);
  EXPECT_GT(spread.albedo_at(hx, hy)[red], surface);
}

// A 5-MP scene is rendered in bands of rows (render_skin_scene): with the
// spread on, each band is made with a margin of rows and cropped, so the
// bands meet without seams.
TEST(SubsurfaceSpread, BandsOfRowsMeetWithoutSeams) {
  const SkinSceneOptions options = options_128(true);
  SceneWeights red = SceneWeights::Zero(1, spectral::kGridSize);
  red(0, band_of(700)) = 1;
  const cv::Mat whole = make_skin_scene(options).render(red);
  const SkinSceneResponse banded = render_skin_scene(options, {red}, 16);
  double worst = 0;
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 128; ++x)
      worst = std::max(worst, static_cast<double>(std::abs(whole.at<float>(y, x) - banded.responses[0].at<float>(y, x))));
  EXPECT_LT(worst, 1e-4);
}

TEST(SubsurfaceSpread, OffIsTheSceneAsBeforeAndBadWidthsAreRefused) {
  SkinSceneOptions off = options_128(false);
  off.subsurface.sigma_red_px = 10;  // unused while off
  const Scene a = make_skin_scene(off), b = make_skin_scene(options_128(false));
  for (int y = 0; y < 128; y += 5)
    for (int x = 0; x < 128; x += 5) ASSERT_EQ(a.albedo_at(x, y)[40], b.albedo_at(x, y)[40]);
  SkinSceneOptions bad = options_128(true);
  bad.subsurface.sigma_blue_px = 4, bad.subsurface.sigma_red_px = 2;
  std::string error;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(error.find("sigma_blue_px <= sigma_red_px"), std::string::npos) << error;
  EXPECT_THROW(make_skin_scene(bad), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::simulators
