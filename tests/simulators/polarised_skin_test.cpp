// The skin scene through a polarised sphere (docs/polarisation.md, "Virtual
// lab physics"): cross captures are the diffuse albedo within the extinction
// leak, parallel − cross is the surface layer, an unpolarised sphere renders
// exactly as before.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>

#include "chromo/simulators/polarisation/polarised_skin.hpp"
#include "chromo/simulators/polarisation/skin_surface.hpp"

namespace chromo::simulators {
namespace {

using drivers::Polarisation;

SkinSceneOptions small_scene() {
  SkinSceneOptions options;
  options.width = 160;
  options.height = 128;
  options.threads = 2;
  return options;
}

// Blue, green and red box channels: 420-480, 520-580, 600-660 nm.
SceneWeights box_channels() {
  SceneWeights weights = SceneWeights::Zero(3, spectral::kGridSize);
  const double bands[3][2] = {{420, 480}, {520, 580}, {600, 660}};
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < spectral::kGridSize; ++i) {
      const double nm = spectral::grid_wavelength_nm(i);
      if (nm >= bands[c][0] && nm <= bands[c][1]) weights(c, i) = 1.0 / 13;
    }
  return weights;
}

struct PolarisedCaptures {
  Scene scene;
  cv::Mat surface;               // the truth of the surface layer
  cv::Mat diffuse;               // the truth, in albedo units (the films' transmission as the white reference sees it)
  cv::Mat cross, parallel;       // in albedo units after the white strip of the same state
};

// Albedo units: each channel divided by the white strip's mean, times ρ_white.
cv::Mat to_albedo(const cv::Mat& response, const Scene& scene) {
  cv::Scalar white_sum(0, 0, 0, 0);
  int count = 0;
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x)
      if (scene.regions().at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(SceneRegion::kWhiteTarget)) {
        const cv::Vec3f v = response.at<cv::Vec3f>(y, x);
        for (int c = 0; c < 3; ++c) white_sum[c] += v[c];
        ++count;
      }
  cv::Mat albedo = response.clone();
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x)
      for (int c = 0; c < 3; ++c)
        albedo.at<cv::Vec3f>(y, x)[c] =
            static_cast<float>(response.at<cv::Vec3f>(y, x)[c] / (white_sum[c] / count) * kWhiteTargetReflectance);
  return albedo;
}

PolarisedCaptures capture(const PolarisedSphere& sphere) {
  const SkinSceneOptions options = small_scene();
  PolarisedCaptures out{make_skin_scene(options), {}, {}, {}, {}};
  const SceneWeights weights = box_channels();
  out.surface = skin_surface_layer(out.scene, options, sphere.view_angle_deg);
  // Diffuse truth: the same channels through both films with no surface layer at all.
  const spectral::Spectrum t = diffuse_transmission(sphere.light_film, sphere.analyser_film);
  SceneWeights filtered = weights;
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < spectral::kGridSize; ++i) filtered(c, i) *= t[i];
  out.diffuse = out.scene.render(filtered);
  for (int y = 0; y < out.scene.height(); ++y)
    for (int x = 0; x < out.scene.width(); ++x)
      if (out.scene.regions().at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(SceneRegion::kSpecular))
        for (int c = 0; c < 3; ++c)
          out.diffuse.at<cv::Vec3f>(y, x)[c] -= static_cast<float>(
              skin_scene_added_reflection(options.width, options.height, x, y) * filtered.row(c).sum());
  out.diffuse = to_albedo(out.diffuse, out.scene);
  out.cross = to_albedo(render_polarised_skin(out.scene, options, weights, Polarisation::kCross, sphere), out.scene);
  out.parallel =
      to_albedo(render_polarised_skin(out.scene, options, weights, Polarisation::kParallel, sphere), out.scene);
  return out;
}

bool is_highlight(const Scene& scene, int x, int y) {
  return scene.regions().at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(SceneRegion::kSpecular);
}

TEST(PolarisedSkin, CrossIsDiffuseWithinTheExtinctionLeakAndParallelMinusCrossIsTheSurfaceLayer) {
  const PolarisedCaptures lab = capture(PolarisedSphere{});  // 1:200 at 550 nm, design view
  // The weakest extinction of each channel's band is at its blue end (1:27 at 420 nm, 1:126 at 520 nm, 1:200 at 600 nm).
  const PolariserFilm film;
  const double cross_leak_bound[3] = {4.0 / film.extinction_ratio_at(420), 4.0 / film.extinction_ratio_at(520),
                                      4.0 / film.extinction_ratio_at(600)};
  int highlight_pixels = 0;
  double worst_green_cross = 0, worst_green_difference = 0, peak_surface = 0;
  for (int y = 0; y < lab.scene.height(); ++y)
    for (int x = 0; x < lab.scene.width(); ++x) {
      if (lab.scene.regions().at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(SceneRegion::kWhiteTarget)) continue;
      const double s = lab.surface.at<float>(y, x);
      for (int c = 0; c < 3; ++c) {
        const double diffuse = lab.diffuse.at<cv::Vec3f>(y, x)[c];
        const double cross = lab.cross.at<cv::Vec3f>(y, x)[c], parallel = lab.parallel.at<cv::Vec3f>(y, x)[c];
        // Cross ≈ diffuse only: above it by no more than the extinction leak of the surface layer.
        EXPECT_GE(cross - diffuse, -1e-5) << x << "," << y << " channel " << c;
        EXPECT_LE(cross - diffuse, cross_leak_bound[c] * s + 1e-5) << x << "," << y << " channel " << c;
        if (c == 1) {
          worst_green_cross = std::max(worst_green_cross, (cross - diffuse) / s);
          worst_green_difference = std::max(worst_green_difference, std::abs((parallel - cross) / 2 - s) / s);
        }
      }
      if (is_highlight(lab.scene, x, y)) {
        ++highlight_pixels;
        peak_surface = std::max(peak_surface, s);
      }
    }
  std::printf("%d highlight pixels, surface layer up to %.3f; green: cross keeps <= %.4f of it, "
              "(parallel - cross)/2 off by <= %.4f of it\n",
              highlight_pixels, peak_surface, worst_green_cross, worst_green_difference);
  EXPECT_GT(highlight_pixels, 50);
  EXPECT_GT(peak_surface, 0.3);  // the scene's highlight (0.3) on the sheen (0.028)
  // Closed forms per wavelength for identical films crossed exactly, c_cross = 4·ER/(1 + ER)² and
  // (c_parallel − c_cross)/2 = (ER − 1)²/(ER + 1)², averaged over the green box weighted by T_P·T_A = T².
  double weight = 0, cross_share = 0, difference_share = 0;
  for (double nm = 520; nm <= 580; nm += 5) {
    const double er = film.extinction_ratio_at(nm), t2 = std::pow(film.transmission_at(nm), 2);
    weight += t2;
    cross_share += t2 * 4 * er / std::pow(1 + er, 2);
    difference_share += t2 * std::pow((er - 1) / (er + 1), 2);
  }
  EXPECT_NEAR(worst_green_cross, cross_share / weight, 2e-4);        // 0.0225: 1:126-1:200 over 520-580 nm
  EXPECT_NEAR(worst_green_difference, 1 - difference_share / weight, 2e-4);
  EXPECT_LT(worst_green_cross, 0.023);
  EXPECT_LT(worst_green_difference, 0.023);  // (parallel − cross)/2 is the surface layer within 2.3% in green
}

TEST(PolarisedSkin, SheenIsExactFresnelAtTheViewAngle) {
  const SkinSceneOptions options = small_scene();
  const Scene scene = make_skin_scene(options);
  const cv::Mat surface = skin_surface_layer(scene, options, 20);
  EXPECT_NEAR(surface.at<float>(120, 10), fresnel_reflectance_unpolarised(1.4, 20 * std::numbers::pi / 180), 1e-7);
  EXPECT_EQ(surface.at<float>(64, options.width - 1), 0.0f);  // the white target is depolarising
}

TEST(PolarisedSkin, TheSecondCamerasCrossCaptureKeepsTwiceItsGeometricLeak) {
  PolarisedSphere design, second;
  second.view_angle_deg = 20;
  second.cross_leak = 0.0107;  // cross_polarisation_leak at azimuth 20°, roughness 0.3 rad
  const PolarisedCaptures a = capture(design), b = capture(second);
  for (int y = 0; y < a.scene.height(); ++y)
    for (int x = 0; x < a.scene.width(); ++x) {
      if (!is_highlight(a.scene, x, y)) continue;
      const double excess = (b.cross.at<cv::Vec3f>(y, x)[1] - b.diffuse.at<cv::Vec3f>(y, x)[1]) -
                            (a.cross.at<cv::Vec3f>(y, x)[1] - a.diffuse.at<cv::Vec3f>(y, x)[1]) *
                                b.surface.at<float>(y, x) / a.surface.at<float>(y, x);
      EXPECT_NEAR(excess, 0.0107 * 1.96 * b.surface.at<float>(y, x), 2e-4 + 0.02 * b.surface.at<float>(y, x));
    }
}

TEST(PolarisedSkin, AnUnpolarisedSphereRendersBitIdenticallyAsBefore) {
  const SkinSceneOptions options = small_scene();
  const Scene scene = make_skin_scene(options);
  const SceneWeights weights = box_channels();
  const cv::Mat before = scene.render(weights);
  for (Polarisation state : {Polarisation::kUnpolarised, Polarisation::kCross}) {
    const cv::Mat now = render_polarised_skin(scene, options, weights, state, std::nullopt);
    ASSERT_EQ(now.type(), before.type());
    EXPECT_EQ(cv::norm(now, before, cv::NORM_INF), 0.0);
    EXPECT_EQ(std::memcmp(now.data, before.data, before.total() * before.elemSize()), 0);
  }
}

}  // namespace
}  // namespace chromo::simulators
