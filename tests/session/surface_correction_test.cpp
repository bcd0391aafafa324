// The polarised measurement with the films known to the estimator
// (docs/polarisation.md, "What the estimator knows of the films"): captures
// made by hand from the capture model a = d + c·s (d diffuse, s the surface
// reflection, c each capture's channel surface factor), noise-free, so the
// surface maps must give s back in every channel and the cross captures d.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "chromo/estimation/highlight_flags.hpp"
#include "chromo/session/method_measurement.hpp"
#include "chromo/session/surface_factors.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::session {
namespace {

constexpr int kWide = 64, kHigh = 48;
constexpr float kDarkLevel = 0.02f;
constexpr double kRho = 0.99;

// Films weaker in the blue: 1:20 at 400 nm to 1:200 at 550 nm, log-linear, flat above.
spectral::Spectrum film_extinction() {
  spectral::Spectrum er;
  for (int i = 0; i < spectral::kGridSize; ++i) {
    const double t = std::clamp((spectral::grid_wavelength_nm(i) - 400) / 150, -0.2, 1.0);
    er[i] = std::exp(std::log(20.0) + t * (std::log(200.0) - std::log(20.0)));
  }
  return er;
}

std::array<float, 3> diffuse_at(int x, int y) {  // a textured skin (registration needs structure)
  const float t = 1.0f + 0.25f * std::sin(x / 3.0f) * std::cos(y / 2.5f);
  return {0.55f * t, 0.35f * t, 0.25f * t};
}
float surface_at(int x, int y) {  // the sheen everywhere, a 0.4 highlight on a disc
  const double r2 = (x - 40.0) * (x - 40.0) + (y - 20.0) * (y - 20.0);
  return static_cast<float>(estimation::kSheenAtNormal + (r2 < 64 ? 0.4 : 0.0));
}

RgbImage flat_image(std::array<float, 3> level) {
  RgbImage image;
  image.width = kWide, image.height = kHigh;
  for (int c = 0; c < 3; ++c) image.planes[c].assign(image.pixels(), level[c]);
  return image;
}

const std::array<float, 3> kWhiteSignal = {0.8f, 0.7f, 0.5f};  // white − dark

// A subject whose albedo is d + c_c·s with the channel factors `factor`.
RgbImage subject(const std::array<double, 3>& factor, const std::array<float, 3>& white_signal, bool clip_red = false) {
  RgbImage image = flat_image({0, 0, 0});
  for (int y = 0; y < kHigh; ++y)
    for (int x = 0; x < kWide; ++x)
      for (int c = 0; c < 3; ++c) {
        const double albedo = diffuse_at(x, y)[c] + factor[c] * surface_at(x, y);
        float raw = static_cast<float>(kDarkLevel + white_signal[c] * albedo / kRho);
        if (clip_red && c == 0) raw = std::min(raw, 1.0f);
        image.planes[c][static_cast<std::size_t>(y) * kWide + x] = raw;
      }
  return image;
}

std::array<double, 3> channel_factors(const spectral::Spectrum& factor, const spectral::CameraSensitivity& camera,
                                      const spectral::Spectrum& illuminant) {
  return {channel_surface_factor(factor, camera, illuminant, 0), channel_surface_factor(factor, camera, illuminant, 1),
          channel_surface_factor(factor, camera, illuminant, 2)};
}

Captures polarised_captures(bool clip_parallel_red = false) {
  Captures c;
  c.camera = spectral::builtin_camera("nikon_d5100");
  c.white_reflectance = kRho;
  c.dark = flat_image({kDarkLevel, kDarkLevel, kDarkLevel});
  const SurfaceFactors factors = surface_factors_of_extinction(film_extinction(), "test films");
  const spectral::Spectrum w57 = spectral::led_spectrum(spectral::LedType::kW57);
  c.recipe = standard_recipe();
  c.captures.resize(3);
  const std::pair<IlluminatedCapture*, spectral::Spectrum> cross[] = {
      {&c.captures[0], spectral::illuminant_d65()},
      {&c.captures[1], w57},
      {&c.captures[2], w57 + spectral::led_spectrum(spectral::LedType::kBlue)}};
  const char* names[] = {"D65'", "W57", "W57+blue"};
  for (int k = 0; k < 3; ++k) {
    auto& [capture, illuminant] = cross[k];
    capture->name = names[k];
    capture->illuminant = illuminant;
    std::array<float, 3> white_signal = kWhiteSignal;
    if (k == 2) white_signal[2] += 0.3f;  // the blue added
    capture->white = flat_image({kDarkLevel + white_signal[0], kDarkLevel + white_signal[1], kDarkLevel + white_signal[2]});
    capture->subject = subject(channel_factors(factors.cross, c.camera, illuminant), white_signal);
  }
  IlluminatedCapture& parallel = c.parallel.emplace(c.captures[0]);
  parallel.name = "D65' parallel";
  parallel.subject = subject(channel_factors(factors.parallel, c.camera, parallel.illuminant), kWhiteSignal, clip_parallel_red);
  return c;
}

TEST(SurfaceFactors, IdenticalFilmsCrossedExactlyFollowTheClosedForms) {
  const SurfaceFactors at200 = surface_factors_of_extinction(spectral::Spectrum::constant(200), "datasheet");
  EXPECT_NEAR(at200.cross[40], 4.0 * 200 / (201.0 * 201.0), 1e-12);  // 0.0198
  EXPECT_NEAR(at200.cross[40], 0.0198, 1e-4);
  EXPECT_NEAR(at200.parallel[40] - at200.cross[40], 2 * (199.0 * 199.0) / (201.0 * 201.0), 1e-12);
  EXPECT_EQ(at200.source, "datasheet");
  // A channel sees the factor averaged with its weights: a constant stays itself,
  // and the blue channel of weaker-blue films keeps more surface light than green.
  const auto camera = spectral::builtin_camera("nikon_d5100");
  EXPECT_NEAR(channel_surface_factor(at200.cross, camera, spectral::illuminant_d65(), 2), at200.cross[40], 1e-12);
  const SurfaceFactors films = surface_factors_of_extinction(film_extinction(), "test films");
  const double blue = channel_surface_factor(films.cross, camera, spectral::illuminant_d65(), 2);
  const double green = channel_surface_factor(films.cross, camera, spectral::illuminant_d65(), 1);
  EXPECT_GT(blue, 1.5 * green);
  EXPECT_LT(blue, 4.0 * 20 / (21.0 * 21.0));  // never more than the 400 nm film's
  // Bad films and channels are refused, named.
  spectral::Spectrum bad = film_extinction();
  bad[10] = 0.5;
  try {
    surface_factors_of_extinction(bad, "x");
    ADD_FAILURE() << "an extinction ratio below 1 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("430"), std::string::npos) << e.what();
  }
  EXPECT_THROW(channel_surface_factor(films.cross, camera, spectral::illuminant_d65(), 3), std::invalid_argument);
  EXPECT_THROW(channel_surface_factor(films.cross, camera, spectral::Spectrum(), 1), std::invalid_argument);
}

TEST(SurfaceCorrection, SurfaceMapsAreTheSurfaceLayerInEveryChannelAndCrossCapturesTheDiffuse) {
  Captures captures = polarised_captures();
  const Measurement before = build_measurement(captures);  // the films unknown
  captures.surface_factors = surface_factors_of_extinction(film_extinction(), "test films");
  const Measurement m = build_measurement(captures);
  ASSERT_TRUE(m.surface_correction);
  EXPECT_EQ(m.surface_correction->source, "test films");
  ASSERT_EQ(m.surface_red.size(), m.surface.size());
  ASSERT_EQ(m.surface_blue.size(), m.surface.size());
  EXPECT_FALSE(before.surface_correction);
  std::size_t highlight = 0;
  double worst_before_blue = 0;
  for (int y = 1; y < kHigh - 1; ++y)
    for (int x = 1; x < kWide - 1; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * kWide + x;
      const double s = surface_at(x, y);
      highlight += s > 0.1;
      EXPECT_NEAR(m.surface_red[i], s, 2e-4 * (1 + 10 * s)) << x << "," << y;
      EXPECT_NEAR(m.surface[i], s, 2e-4 * (1 + 10 * s)) << x << "," << y;
      EXPECT_NEAR(m.surface_blue[i], s, 2e-4 * (1 + 10 * s)) << x << "," << y;
      // Cross captures: the diffuse albedo plus the sheen's share (as on
      // skin), blue-only channel included; on skin exactly as captured.
      const auto d = diffuse_at(x, y);
      for (int c = 0; c < 3; ++c) {
        const double sheen = m.surface_correction->cross_factor[0][c] * estimation::kSheenAtNormal;
        EXPECT_NEAR(m.measured[i * 4 + c], d[c] + sheen, 2e-4) << x << "," << y << " channel " << c;
        if (s < 0.1) EXPECT_EQ(m.measured[i * 4 + c], before.measured[i * 4 + c]);
      }
      const auto& factor = m.surface_correction->cross_factor;  // blue-only: the mix's B minus W57's, per their whites
      const double blue_only_factor = (factor[2][2] * (kWhiteSignal[2] + 0.3) - factor[1][2] * kWhiteSignal[2]) / 0.3;
      EXPECT_NEAR(m.measured[i * 4 + 3], d[2] + blue_only_factor * estimation::kSheenAtNormal, 5e-4) << x << "," << y;
      // Without the films: G short by the extinction, the blue keeping the surface light.
      EXPECT_LT(before.surface[i], m.surface[i]);
      worst_before_blue = std::max(worst_before_blue, static_cast<double>(before.measured[i * 4 + 2] - d[2]));
      // The photographs stay as captured.
      EXPECT_EQ(m.photographs[0].rgb[i][2], before.photographs[0].rgb[i][2]);
    }
  EXPECT_GT(highlight, 150u);
  EXPECT_EQ(m.surface_correction->corrected_pixels, highlight);  // where S stands above the sheen
  EXPECT_NEAR(m.surface_correction->sheen_reference[1], estimation::kSheenAtNormal, 1e-4);
  EXPECT_GT(worst_before_blue, 0.01);  // 0.4 · the blue channel's c_cross
}

TEST(SurfaceCorrection, ASaturatedParallelChannelTakesTheGreenSurfaceMap) {
  Captures captures = polarised_captures(true);
  captures.surface_factors = surface_factors_of_extinction(film_extinction(), "test films");
  const Measurement m = build_measurement(captures);
  std::size_t clipped = 0;
  for (int y = 1; y < kHigh - 1; ++y)
    for (int x = 1; x < kWide - 1; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * kWide + x;
      if (captures.parallel->subject.planes[0][i] < 0.999f) continue;
      ++clipped;
      EXPECT_LT(m.surface_red[i], surface_at(x, y) - 0.01);  // a lower bound there
      EXPECT_NEAR(m.measured[i * 4 + 0],
                  diffuse_at(x, y)[0] + m.surface_correction->cross_factor[0][0] * estimation::kSheenAtNormal, 2e-4)
          << x << "," << y;
    }
  EXPECT_GT(clipped, 20u);
}

TEST(SurfaceCorrection, FilmsThatDoNotPolariseAreRefused) {
  Captures captures = polarised_captures();
  captures.surface_factors = surface_factors_of_extinction(spectral::Spectrum::constant(1.0), "no films");
  try {
    build_measurement(captures);
    ADD_FAILURE() << "films of extinction 1:1 were accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no films"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace chromo::session
