#include "chromo/maps/reconstruction.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>

#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/delta_e.hpp"

namespace chromo::maps {
namespace {

TEST(Reconstruction, StatisticsOfAKnownList) {
  const DeltaEStats s = delta_e_stats({4, 1, 3, 2, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20});
  EXPECT_DOUBLE_EQ(s.mean, 10.5);
  EXPECT_DOUBLE_EQ(s.median, 11);  // nearest rank
  EXPECT_DOUBLE_EQ(s.p95, 19);
  EXPECT_DOUBLE_EQ(s.max, 20);
  EXPECT_EQ(delta_e_stats({}).pixels, 0u);
}

// The camera → XYZ matrix reproduces the colour of skin closely enough for
// photograph comparisons (skin is not in the ColorChecker fit).
TEST(Reconstruction, CameraMatrixGivesSkinColourUnderEveryLed) {
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  const auto skin = simulators::random_skin_parameters(200, {0.005, 0.005, 0, 0}, {0.3, 0.2, 1, 0.1}, 4);
  for (const spectral::NamedIlluminant& i : spectral::relight_illuminants()) {
    if (i.name == "R" || i.name == "G" || i.name == "B") continue;  // a 3×3 matrix cannot fit narrow-band light
    const auto rgb = relit_camera_rgb(skin, camera, i.spectrum);
    const auto lab = relit_lab(skin, i.spectrum);
    const Eigen::Matrix3d m = camera_to_xyz_matrix(camera, i.spectrum);
    const spectral::Xyz white = spectral::white_point(i.spectrum);
    std::vector<double> de;
    for (std::size_t k = 0; k < skin.size(); ++k) {
      const Eigen::Vector3d x = m * rgb[k];
      de.push_back(spectral::delta_e94(lab[k], spectral::lab_from_xyz({x[0], x[1], x[2]}, white)));
    }
    EXPECT_LT(delta_e_stats(de).mean, 2.0) << i.name;
  }
}

TEST(Reconstruction, PhotographComparisonIsZeroForTheTruthAndGrowsWithError) {
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  auto truth = simulators::random_skin_parameters(300, {0.005, 0.005, 0, 0}, {0.3, 0.2, 1, 0.1}, 5);
  auto wrong = truth;
  for (estimation::SkinParameters& p : wrong) p.cm *= 1.2;
  const spectral::Spectrum& w57 = spectral::led_spectrum(spectral::LedType::kW57);
  const auto photo = relit_camera_rgb(truth, camera, w57);
  EXPECT_NEAR(photo_delta_e94(photo, relit_camera_rgb(truth, camera, w57), camera, w57).mean, 0.0, 1e-9);
  const DeltaEStats s = photo_delta_e94(photo, relit_camera_rgb(wrong, camera, w57), camera, w57);
  EXPECT_GT(s.mean, 0.3);
  EXPECT_GE(s.p95, s.median);
  // The same error measured on the spectra directly agrees within the matrix's error.
  EXPECT_NEAR(s.mean, delta_e_stats(relit_delta_e94(truth, wrong, w57)).mean, 0.5);
  // A mask selects pixels.
  std::unique_ptr<bool[]> half(new bool[truth.size()]);
  for (std::size_t i = 0; i < truth.size(); ++i) half[i] = i % 2 == 0;
  EXPECT_EQ(photo_delta_e94(photo, photo, camera, w57, std::span<const bool>(half.get(), truth.size())).pixels,
            truth.size() / 2);
}


// The relit comparison converts each photograph to Lab once (photo_lab_map)
// and compares it with the reconstruction and with its own noisy copy: the
// same ΔE94 as converting both sides of each pair, computed here pixel by
// pixel from the matrix, the white and the same draws; NaN where a side is
// not finite. The library's two noisy paths agree bit for bit; against this
// file's own arithmetic the bound is 1e-12 relative, since the tests compile
// at -O1 and the library at -O3, which contract multiply-adds differently
// (tests/README.md "CI time"). Over 65,536 pixels so the maps run on every core.
TEST(Reconstruction, ThePhotographsLabOnceGivesTheSameFigures) {
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  const spectral::Spectrum& w57 = spectral::led_spectrum(spectral::LedType::kW57);
  const auto skin = simulators::random_skin_parameters(300, {0.005, 0.005, 0, 0}, {0.3, 0.2, 1, 0.1}, 6);
  auto wrong = skin;
  for (estimation::SkinParameters& p : wrong) p.ch *= 1.3;
  const auto a = relit_camera_rgb(skin, camera, w57), b = relit_camera_rgb(wrong, camera, w57);
  std::vector<Eigen::Vector3d> photo, relit;
  for (std::size_t k = 0; photo.size() < 70000; k = (k + 1) % a.size()) photo.push_back(a[k]), relit.push_back(b[k]);
  photo[5][1] = std::numeric_limits<double>::quiet_NaN();
  relit[7][0] = std::numeric_limits<double>::infinity();
  const std::array<estimation::ChannelNoise, 3> noise{estimation::ChannelNoise{0.01, 0.0002, 1.5, 0},
                                                      estimation::ChannelNoise{0.01, 0.0002, 1.5, 0},
                                                      estimation::ChannelNoise{0.01, 0.0002, 1.5, 0}};
  const Eigen::Matrix3d m = camera_to_xyz_matrix(camera, w57);
  const spectral::Xyz white = spectral::white_point(w57);
  auto lab = [&](const Eigen::Vector3d& rgb) {
    const Eigen::Vector3d x = m * rgb;
    return spectral::lab_from_xyz({x[0], x[1], x[2]}, white);
  };
  std::mt19937_64 random(3);
  std::normal_distribution<double> normal;
  const std::vector<spectral::Lab> photo_lab = photo_lab_map(photo, camera, w57);
  const std::vector<double> compared = delta_e94_map(photo_lab, photo_lab_map(relit, camera, w57));
  const std::vector<double> noisy = photograph_noise_delta_e94_map(photo, photo_lab, noise, camera, w57, 3);
  const std::vector<double> noisy_again = photograph_noise_delta_e94_map(photo, noise, camera, w57, 3);
  ASSERT_EQ(noisy.size(), noisy_again.size());
  for (std::size_t i = 0; i < noisy.size(); ++i)
    ASSERT_TRUE(noisy[i] == noisy_again[i] || (std::isnan(noisy[i]) && std::isnan(noisy_again[i]))) << i;
  for (std::size_t i = 0; i < photo.size(); ++i) {
    Eigen::Vector3d drawn = photo[i];
    for (int c = 0; c < 3; ++c) drawn[c] += std::sqrt(noise[static_cast<std::size_t>(c)].variance(drawn[c])) * normal(random);
    if (i == 5 || i == 7) {
      EXPECT_TRUE(std::isnan(compared[i])) << i;
      if (i == 5) EXPECT_TRUE(std::isnan(noisy[i]));
      continue;
    }
    const double compared_here = spectral::delta_e94(lab(photo[i]), lab(relit[i]));
    const double noisy_here = spectral::delta_e94(lab(photo[i]), lab(drawn));
    ASSERT_NEAR(compared[i], compared_here, 1e-12 * std::max(1.0, compared_here)) << i;
    ASSERT_NEAR(noisy[i], noisy_here, 1e-12 * std::max(1.0, noisy_here)) << i;
  }
  EXPECT_THROW(photograph_noise_delta_e94_map(photo, std::span(photo_lab).first(3), noise, camera, w57),
               std::invalid_argument);
  EXPECT_THROW(delta_e94_map(photo_lab, std::span(photo_lab).first(3)), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::maps
