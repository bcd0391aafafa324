// The virtual lab's skin scene: albedo straight from the forward model, the
// regions the model cannot explain, the white target, reproducibility.
#include <gtest/gtest.h>

#include <array>

#include "chromo/estimation/skin_model.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::simulators {
namespace {

const Scene& scene_128() {
  static const Scene scene = [] {
    SkinSceneOptions options;
    options.width = 128;
    options.height = 128;
    return make_skin_scene(options);
  }();
  return scene;
}

SceneRegion region_at(const Scene& scene, int x, int y) {
  return static_cast<SceneRegion>(scene.regions().at<std::uint8_t>(y, x));
}

estimation::SkinParameters parameters_at(const Scene& scene, int x, int y) {
  return {scene.cm().at<float>(y, x), scene.ch().at<float>(y, x), scene.bm().at<float>(y, x),
          scene.che().at<float>(y, x)};
}

TEST(SkinScene, EveryRegionIsPresentAndLabelled) {
  std::array<int, 7> counts{};
  const Scene& scene = scene_128();
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x) ++counts.at(scene.regions().at<std::uint8_t>(y, x));
  for (int r = 0; r < 7; ++r) EXPECT_GT(counts[r], 0) << region_name(static_cast<SceneRegion>(r));
  EXPECT_GT(counts[0], scene.width() * scene.height() / 2);  // mostly skin
}

TEST(SkinScene, SkinAlbedoIsTheForwardModelsAtTheTruthParameters) {
  const Scene& scene = scene_128();
  const estimation::SkinModel model;
  int checked = 0;
  for (int y = 0; y < scene.height(); y += 7)
    for (int x = 0; x < scene.width(); x += 7) {
      if (region_at(scene, x, y) != SceneRegion::kSkin) continue;
      const auto p = parameters_at(scene, x, y);
      EXPECT_FALSE(estimation::range_violation(p).has_value());
      // The stored truth maps are float; the albedo was computed from the double parameters.
      const spectral::Spectrum expected = model.albedo(p);
      const spectral::Spectrum stored = scene.albedo_at(x, y);
      for (int i = 0; i < spectral::kGridSize; i += 10) EXPECT_NEAR(stored[i], expected[i], 2e-4 * expected[i] + 1e-6);
      ++checked;
    }
  EXPECT_GT(checked, 100);
}

TEST(SkinScene, UnexplainedRegionsDepartFromTheModel) {
  const Scene& scene = scene_128();
  const estimation::SkinModel model;
  double vein_ratio = 0, specular_excess = 0;
  int veins = 0, speculars = 0;
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x) {
      const auto region = region_at(scene, x, y);
      if (region == SceneRegion::kVein) {
        // Darker than the model at the same (raised-Ch) parameters: the deoxygenated part.
        vein_ratio += scene.albedo_at(x, y)[36] / model.albedo(parameters_at(scene, x, y))[36];  // 560 nm
        ++veins;
      } else if (region == SceneRegion::kSpecular) {
        specular_excess += scene.albedo_at(x, y)[0] - model.albedo(parameters_at(scene, x, y))[0];
        ++speculars;
      } else if (region == SceneRegion::kWhiteTarget) {
        EXPECT_FLOAT_EQ(scene.albedo_at(x, y)[40], kWhiteTargetReflectance);
      }
    }
  ASSERT_GT(veins, 0);
  ASSERT_GT(speculars, 0);
  EXPECT_LT(vein_ratio / veins, 0.85);
  EXPECT_GT(specular_excess / speculars, 0.06);  // flat surface reflection added
}

TEST(SkinScene, SameSeedSameSceneOtherSeedOtherScene) {
  SkinSceneOptions options;
  options.width = 32;
  options.height = 32;
  const Scene a = make_skin_scene(options), b = make_skin_scene(options);
  options.seed = 2;
  const Scene c = make_skin_scene(options);
  EXPECT_EQ(a.albedo_at(5, 9).values().matrix(), b.albedo_at(5, 9).values().matrix());
  EXPECT_NE(a.cm().at<float>(9, 5), c.cm().at<float>(9, 5));
  options.width = 4;
  EXPECT_THROW(make_skin_scene(options), std::invalid_argument);
}

TEST(Scene, RenderIsTheWeightedSumOfTheAlbedo) {
  const Scene white = make_white_target_scene(8, 4);
  Eigen::Matrix<double, Eigen::Dynamic, spectral::kGridSize> weights(2, spectral::kGridSize);
  weights.row(0).setConstant(1.0 / spectral::kGridSize);
  weights.row(1).setZero();
  weights(1, 10) = 2.0;
  const cv::Mat out = white.render(weights);
  ASSERT_EQ(out.type(), CV_32FC2);
  EXPECT_NEAR(out.at<cv::Vec2f>(3, 7)[0], kWhiteTargetReflectance, 1e-6);
  EXPECT_NEAR(out.at<cv::Vec2f>(3, 7)[1], 2 * kWhiteTargetReflectance, 1e-6);
}

// The bench's 5-MP scenes are rendered band by band: the bands must be the
// same scene (fields, moles, strands, regions) as the whole.
TEST(SkinScene, BandsRenderTheSameSceneAsTheWhole) {
  SkinSceneOptions options;
  options.width = 64;
  options.height = 48;
  options.white_patch = false;
  options.threads = 2;
  const Scene whole = make_skin_scene(options);
  std::vector<SceneWeights> weights(2, SceneWeights(3, spectral::kGridSize));
  weights[0].setRandom();
  weights[1] = weights[0].cwiseAbs();
  const SkinSceneResponse bands = render_skin_scene(options, weights, 7);  // 7 rows: a band boundary inside every feature
  for (std::size_t k = 0; k < weights.size(); ++k) {
    const cv::Mat expected = whole.render(weights[k]);
    EXPECT_EQ(cv::norm(expected, bands.responses[k], cv::NORM_INF), 0.0) << k;
  }
  EXPECT_EQ(cv::norm(whole.regions(), bands.regions, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(whole.cm(), bands.cm, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(whole.che(), bands.che, cv::NORM_INF), 0.0);
  int unexplained = 0;  // the scene has its features in this size too
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) unexplained += region_at(whole, x, y) != SceneRegion::kSkin;
  EXPECT_GT(unexplained, 100);
  // A window (the bench's tiny sensors look at a part of a large scene).
  options.row_begin = 5, options.row_count = 20, options.column_begin = 10, options.column_count = 30;
  const SkinSceneResponse window = render_skin_scene(options, weights, 6);
  const cv::Rect rect(10, 5, 30, 20);
  EXPECT_EQ(cv::norm(whole.render(weights[0])(rect), window.responses[0], cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(whole.regions()(rect), window.regions, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(whole.ch()(rect), window.ch, cv::NORM_INF), 0.0);
  options.column_begin = 40;
  EXPECT_THROW(render_skin_scene(options, weights), std::invalid_argument);
  options.column_begin = options.column_count = 0;
  options.row_begin = 40;
  options.row_count = 9;
  EXPECT_THROW(render_skin_scene(options, weights), std::invalid_argument);
  options.row_count = 8;
  EXPECT_EQ(render_skin_scene(options, weights, 3).regions.rows, 8);
  EXPECT_THROW(render_skin_scene(options, weights, 0), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::simulators
