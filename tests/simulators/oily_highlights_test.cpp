// Oily regions of the skin scene (scene.hpp OilyHighlights,
// skin_scene_oily_reflection; docs/polarisation.md "Oily highlights"): off by
// default (the scene as before), peaks at n_k·σ spaced 1-20σ, the lobe's
// lit share falling toward the dome's rim faster for a smoother film, and the
// polarised render's surface layer carrying them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "chromo/simulators/polarisation/polarised_skin.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::simulators {
namespace {

constexpr double kSigma = 0.0015;

SkinSceneOptions oily_scene(int count) {
  SkinSceneOptions o;
  o.width = 160, o.height = 128, o.seed = 3, o.threads = 2;
  o.oily.count = count;
  o.oily.sigma_reflectance = kSigma;
  return o;
}

TEST(OilyHighlights, OffByDefaultAndTheSceneUnchangedOutsideTheOil) {
  SkinSceneOptions plain = oily_scene(0);
  const Scene before = make_skin_scene(plain);
  const Scene after = make_skin_scene(oily_scene(6));
  std::size_t oily_pixels = 0;
  for (int y = 0; y < before.height(); ++y)
    for (int x = 0; x < before.width(); ++x) {
      const double oil = skin_scene_oily_reflection(oily_scene(6), x, y);
      EXPECT_EQ(skin_scene_oily_reflection(plain, x, y), 0.0);
      const bool white = after.regions().at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(SceneRegion::kWhiteTarget);
      for (int i = 0; i < spectral::kGridSize; i += 20) {
        const double expected = before.albedo_at(x, y)[i] + (white ? 0.0 : oil);
        ASSERT_NEAR(after.albedo_at(x, y)[i], expected, 1e-6) << x << "," << y;
      }
      if (oil > 0 && !white) {
        ++oily_pixels;
        EXPECT_EQ(after.regions().at<std::uint8_t>(y, x), static_cast<std::uint8_t>(SceneRegion::kSpecular));
      }
    }
  EXPECT_GT(oily_pixels, 300u);
}

TEST(OilyHighlights, StrengthsSpanOneToTwentySigma) {
  // One region alone peaks at its strength (1σ); the strongest of several at 20σ (regions may overlap and add).
  double peak_one = 0, peak_many = 0;
  const SkinSceneOptions one = oily_scene(1), many = oily_scene(8);
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 160; ++x) {
      peak_one = std::max(peak_one, skin_scene_oily_reflection(one, x + 0.5, y + 0.5));
      peak_many = std::max(peak_many, skin_scene_oily_reflection(many, x + 0.5, y + 0.5));
    }
  EXPECT_NEAR(peak_one / kSigma, 1.0, 0.03);
  EXPECT_GE(peak_many / kSigma, 19.0);
  EXPECT_LE(peak_many / kSigma, 40.0);
  SkinSceneOptions bad = oily_scene(3);
  bad.oily.sigma_reflectance = 0;
  std::string error;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(error.find("sigma_reflectance"), std::string::npos);
}

TEST(OilyHighlights, TheLobeFadesTowardTheRimFasterForASmoothFilm) {
  // A single region: the reflection along a ray from its peak falls
  // monotonically; at 60% of the radius (mirror direction 48° of the 70° lit
  // cap) a rough film (0.35 rad) keeps less of its peak than a smooth one
  // (0.05 rad) keeps... and near the rim the smooth one drops to zero first.
  auto profile = [](double roughness) {
    SkinSceneOptions o = oily_scene(1);
    o.oily.min_roughness_rad = o.oily.max_roughness_rad = roughness;
    double peak = 0;
    int px = 0, py = 0;
    for (int y = 0; y < 128; ++y)
      for (int x = 0; x < 160; ++x)
        if (const double v = skin_scene_oily_reflection(o, x, y); v > peak) peak = v, px = x, py = y;
    std::vector<double> along;
    for (int d = 0; d < 40; ++d) along.push_back(skin_scene_oily_reflection(o, px + d, py) / peak);
    return along;
  };
  const std::vector<double> smooth = profile(0.05), rough = profile(0.35);
  for (std::size_t d = 1; d < smooth.size(); ++d) {
    EXPECT_LE(smooth[d], smooth[d - 1] + 0.05);
    EXPECT_LE(rough[d], rough[d - 1] + 0.05);
  }
  // Where the mirror direction nears the lit cap's edge (2t ≈ 70°, r ≈ 0.875 R), the smooth
  // film has lost almost all its lobe, the rough one keeps part of it.
  std::size_t smooth_gone = smooth.size(), rough_gone = rough.size();
  for (std::size_t d = 0; d < smooth.size(); ++d) if (smooth[d] < 0.01 && smooth_gone == smooth.size()) smooth_gone = d;
  for (std::size_t d = 0; d < rough.size(); ++d) if (rough[d] < 0.01 && rough_gone == rough.size()) rough_gone = d;
  EXPECT_LE(smooth_gone, rough_gone);
}

TEST(OilyHighlights, ThePolarisedSurfaceLayerCarriesThem) {
  const SkinSceneOptions o = oily_scene(6);
  const Scene scene = make_skin_scene(o);
  const cv::Mat surface = skin_surface_layer(scene, o, 0);
  int checked = 0;
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x) {
      if (scene.regions().at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(SceneRegion::kWhiteTarget)) continue;
      EXPECT_NEAR(surface.at<float>(y, x), 0.02778 + skin_scene_surface_highlight(o, x, y), 2e-5);
      ++checked;
    }
  EXPECT_GT(checked, 15000);
}

}  // namespace
}  // namespace chromo::simulators
