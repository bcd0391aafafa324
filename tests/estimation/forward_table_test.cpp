#include "chromo/estimation/forward_table.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <unistd.h>

#include "chromo/estimation/appearance.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "estimation_fixture.hpp"

namespace chromo::estimation {
namespace {

TEST(ForwardTable, NodesEqualTheDirectModel) {
  const MeasurementSet set = testing::method_set();
  const auto table = testing::built_method_table();
  const Eigen::MatrixXd w = set.weights();
  const SkinModel model;
  for (const auto& [i_cm, i_ch, i_bm, i_che] : {std::array{0, 0, 0, 0}, std::array{40, 40, 20, 20},
                                                std::array{12, 30, 14, 0}, std::array{25, 3, 7, 11}}) {
    const SkinParameters p{table->node_value(0, i_cm), table->node_value(1, i_ch), table->node_value(2, i_bm),
                           table->node_value(3, i_che)};
    const Eigen::VectorXd direct = w * model.albedo(p).values().matrix();
    std::vector<double> interpolated(table->channels());
    table->predict(table->to_grid(p), interpolated.data());
    for (int c = 0; c < set.size(); ++c) {
      EXPECT_NEAR(table->node(i_cm, i_ch, i_bm, i_che)[c], direct[c], 1e-6 * std::max(1.0, direct[c]));
      EXPECT_NEAR(interpolated[c], direct[c], 1e-5);
    }
  }
}

// The auto model's appearance table: CIELAB under the six LEDs and D65 at a
// node of its own grid (measurement-grid coordinates, every second node)
// equals the direct model's colour; between nodes it stays close to it; its
// Jacobian is the derivative of the interpolant (central differences inside
// one cell).
TEST(AppearanceTable, LabMatchesTheModelAndItsJacobianTheInterpolant) {
  const auto appearance = AppearanceTable::shared(TableGrid{}, {});
  const auto illuminants = spectral::relight_illuminants();
  ASSERT_EQ(static_cast<int>(illuminants.size()), AppearanceTable::kIlluminants);
  const SkinModel model;
  for (const GridPoint& node : {GridPoint{4, 10, 14, 0}, GridPoint{30, 20, 4, 16}, GridPoint{40, 40, 20, 20}}) {
    double lab[AppearanceTable::kChannels];
    appearance->lab(node, lab);
    const spectral::Spectrum albedo = model.albedo(testing::method_table()->from_grid(node));
    for (int l = 0; l < AppearanceTable::kIlluminants; ++l) {
      const spectral::Spectrum& e = illuminants[l].spectrum;
      const spectral::Lab direct =
          spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, e), spectral::white_point(e));
      EXPECT_NEAR(lab[3 * l], direct.L, 2e-4) << illuminants[l].name;
      EXPECT_NEAR(lab[3 * l + 1], direct.a, 2e-4) << illuminants[l].name;
      EXPECT_NEAR(lab[3 * l + 2], direct.b, 2e-4) << illuminants[l].name;
    }
  }
  // Between nodes: mean ΔE*ab against the direct model over random points.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  const auto n = testing::method_table()->nodes();
  double sum = 0, worst = 0;
  const int points = 300;
  for (int i = 0; i < points; ++i) {
    const GridPoint x{u(rng) * (n[0] - 1), u(rng) * (n[1] - 1), u(rng) * (n[2] - 1), u(rng) * (n[3] - 1)};
    double lab[AppearanceTable::kChannels];
    appearance->lab(x, lab);
    const spectral::Spectrum albedo = model.albedo(testing::method_table()->from_grid(x));
    for (int l = 0; l < AppearanceTable::kIlluminants; ++l) {
      const spectral::Spectrum& e = illuminants[l].spectrum;
      const spectral::Lab d = spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, e), spectral::white_point(e));
      const double de = std::hypot(lab[3 * l] - d.L, lab[3 * l + 1] - d.a, lab[3 * l + 2] - d.b);
      sum += de, worst = std::max(worst, de);
    }
  }
  std::printf("appearance table between nodes: mean dE*ab %.4f, max %.3f\n", sum / (points * 7), worst);
  EXPECT_LT(sum / (points * 7), 0.1);  // measured 0.066, max 0.98
  const GridPoint x{12.3, 25.6, 8.45, 3.2};
  double lab[AppearanceTable::kChannels], jacobian[AppearanceTable::kChannels * 4];
  appearance->lab(x, lab, jacobian);
  for (int k = 0; k < 4; ++k) {
    GridPoint up = x, down = x;
    up[k] += 1e-4, down[k] -= 1e-4;
    double lab_up[AppearanceTable::kChannels], lab_down[AppearanceTable::kChannels];
    appearance->lab(up, lab_up);
    appearance->lab(down, lab_down);
    for (int i = 0; i < AppearanceTable::kChannels; ++i) {
      const double numeric = (lab_up[i] - lab_down[i]) / 2e-4;
      EXPECT_NEAR(jacobian[i * 4 + k], numeric, 1e-4 * std::max(1.0, std::abs(numeric))) << i << " " << k;
    }
  }
  EXPECT_THROW(AppearanceTable(testing::method_table(), TableGrid{}), std::invalid_argument);
}

TEST(ForwardTable, TwoDModelIsASliceOfNodes) {
  const auto table = testing::method_table();
  EXPECT_DOUBLE_EQ(table->node_value(2, 14), 0.7);
  EXPECT_DOUBLE_EQ(table->node_value(3, 0), 0.0);
}

// The grid's interpolation error, measured in colour: a table of CIE XYZ under
// D65 (the observer as "camera") against the direct model at random
// parameters over the whole MODEL.md box. Target ≤ 0.02 mean ΔE94.
TEST(ForwardTable, InterpolationErrorUnderD65IsBelowTwoHundredthsDeltaE94) {
  const spectral::Observer& o = spectral::cie1931_observer();
  const MeasurementSet xyz_set = rgb_measurement_set({"cie1931", {o.x_bar, o.y_bar, o.z_bar}}, spectral::illuminant_d65());
  const ForwardTable table = ForwardTable::build(xyz_set, TableGrid{});
  const auto parameters = simulators::random_skin_parameters(4000, {0.001, 0.001, 0, 0}, {0.5, 0.32, 1, 0.1}, 11);
  const SkinModel model;
  const spectral::Xyz white = spectral::white_point(spectral::illuminant_d65());
  double sum = 0;
  for (const SkinParameters& p : parameters) {
    double v[3];
    table.predict(table.to_grid(p), v);
    const spectral::Lab direct =
        spectral::lab_from_xyz(spectral::xyz_of_reflectance(model.albedo(p), spectral::illuminant_d65()), white);
    sum += spectral::delta_e94(direct, spectral::lab_from_xyz({v[0] * white.X, v[1] * white.Y, v[2] * white.Z}, white));
  }
  const double mean = sum / parameters.size();
  EXPECT_LE(mean, 0.02);
  EXPECT_GT(mean, 0.0);
}

TEST(ForwardTable, JacobianMatchesFiniteDifferences) {
  const auto table = testing::built_method_table();
  const GridPoint x{12.3, 20.7, 5.4, 3.2};
  std::vector<double> v(table->channels()), jac(table->channels() * 4);
  table->predict(x, v.data(), jac.data());
  for (int k = 0; k < 4; ++k) {
    GridPoint a = x, b = x;
    a[k] -= 1e-4, b[k] += 1e-4;
    std::vector<double> va(table->channels()), vb(table->channels());
    table->predict(a, va.data()), table->predict(b, vb.data());
    for (int c = 0; c < table->channels(); ++c) EXPECT_NEAR(jac[c * 4 + k], (vb[c] - va[c]) / 2e-4, 1e-6);
  }
}

TEST(ForwardTable, CacheIsReusedAndRebuiltWhenAnInputChanges) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("chromo_table_cache_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const TableGrid small{9, 9, 11, 5};
  MeasurementSet set = testing::method_set();
  bool rebuilt = false;
  const auto first = ForwardTable::load_or_build(set, small, dir, &rebuilt);
  EXPECT_TRUE(rebuilt);
  const auto second = ForwardTable::load_or_build(set, small, dir, &rebuilt);
  EXPECT_FALSE(rebuilt);
  EXPECT_EQ(first->values(), second->values());
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);

  // Another illuminant → another key → a new file.
  set.channels[3].illuminant *= 0.5;
  set.channels[3].illuminant += spectral::led_spectrum(spectral::LedType::kGreen) * 0.1;
  const auto third = ForwardTable::load_or_build(set, small, dir, &rebuilt);
  EXPECT_TRUE(rebuilt);
  EXPECT_NE(third->key(), first->key());

  // A truncated file is rebuilt, never read as a table.
  MeasurementSet original = testing::method_set();
  const std::uint64_t key = ForwardTable::cache_key(original, small);
  char name[64];
  std::snprintf(name, sizeof name, "forward_table_%016llx.bin", static_cast<unsigned long long>(key));
  ASSERT_TRUE(std::filesystem::exists(dir / name));
  std::filesystem::resize_file(dir / name, 100);
  const auto fourth = ForwardTable::load_or_build(original, small, dir, &rebuilt);
  EXPECT_EQ(fourth->key(), key);
  EXPECT_TRUE(rebuilt);
  EXPECT_EQ(fourth->values(), first->values());
  EXPECT_GT(std::filesystem::file_size(dir / name), 100u);
  std::filesystem::remove_all(dir);
}

TEST(ForwardTable, RejectsAGridWithoutTheTwoDSlice) {
  std::string error;
  EXPECT_FALSE((TableGrid{9, 9, 12, 5}.IsValid(&error)));
  EXPECT_NE(error.find("0.7"), std::string::npos);
  EXPECT_THROW(ForwardTable::build(testing::method_set(), TableGrid{9, 9, 12, 5}), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::estimation
