#include "chromo/maps/reconstruction.hpp"

#include <gtest/gtest.h>

#include <memory>

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

}  // namespace
}  // namespace chromo::maps
