#include "chromo/estimation/inverter.hpp"
#include "chromo/estimation/inverse_table.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "chromo/simulators/scene/synthetic.hpp"
#include "estimation_fixture.hpp"

namespace chromo::estimation {
namespace {

// σ = 0.01 albedo on every channel: χ² in units of a typical camera noise.
std::vector<double> unit_weights(int channels) { return std::vector<double>(channels, 100.0); }

// A measurement equal to a node's stored values is inside the gamut: the
// fast fit must explain it to within its convergence χ² (0.1σ per channel),
// wherever in the table the node is.
TEST(FastInverter, NodeValuesAreFittedExactly) {
  const auto table = testing::method_table();
  const FastInverter fast(table);
  const auto n = table->nodes();
  std::mt19937 rng(5);
  const std::vector<double> w = unit_weights(table->channels());
  int exact = 0;
  const int trials = 400;
  for (int t = 0; t < trials; ++t) {
    const int i_cm = std::uniform_int_distribution<int>(0, 32)(rng);  // Cm ≤ 0.23: not black
    const int i_ch = std::uniform_int_distribution<int>(0, n[1] - 1)(rng);
    const int i_bm = std::uniform_int_distribution<int>(0, n[2] - 1)(rng);
    const int i_che = std::uniform_int_distribution<int>(0, n[3] - 1)(rng);
    std::vector<double> m(table->channels());
    const float* v = table->node(i_cm, i_ch, i_bm, i_che);
    for (int c = 0; c < table->channels(); ++c) m[c] = v[c];
    const Fit f = fast.fit(m.data(), w.data(), 4);
    if (f.chi2 <= FastInverterOptions{}.converged_chi2) ++exact;
  }
  EXPECT_GE(exact, trials * 99 / 100);
}

// Noise-free in-gamut skin: the fast fit reaches the exhaustive search's
// residual (it seeds from the best node of its measurement cell, not one
// arbitrary node, so it does not stop in another branch's local minimum).
TEST(FastInverter, ReachesTheExhaustiveResidualOnNoiseFreeSkin) {
  const auto table = testing::method_table();
  const FastInverter fast(table);
  const ExhaustiveInverter exhaustive(table);
  MeasurementSet set = testing::method_set();
  simulators::SyntheticOptions o;
  o.pixels = 200;
  o.low = {0.005, 0.005, 0.0, 0.0};
  o.high = {0.3, 0.2, 1.0, 0.1};
  o.noise.noise_scale = 0;
  const simulators::SyntheticFrame f = simulators::make_synthetic_frame(set, o);
  const int c_count = table->channels();
  const std::vector<double> w = unit_weights(c_count);
  int close = 0;
  double fast_sum = 0;
  for (std::size_t i = 0; i < f.pixels(); ++i) {
    std::vector<double> m(table->channels());
    for (int c = 0; c < c_count; ++c) m[c] = f.clean[i * c_count + c];
    const Fit a = fast.fit(m.data(), w.data(), 4), b = exhaustive.fit(m.data(), w.data(), 4);
    fast_sum += a.chi2;
    if (a.chi2 <= b.chi2 + 0.01) ++close;
  }
  EXPECT_GE(close, static_cast<int>(f.pixels()) * 97 / 100);
  EXPECT_LE(fast_sum / f.pixels(), 0.01);
}

TEST(FastInverter, InverseTableCoversOnlyPartOfMeasurementSpace) {
  const FastInverter fast(testing::method_table());
  const double box_cells = 48.0 * 48 * 48 * 48;
  const double occupied = fast.inverse_table().occupied_cells() / box_cells;
  EXPECT_GT(occupied, 0.0005);
  EXPECT_LT(occupied, 0.05);  // most of the key box is outside the gamut
  // The fill along the thin axes reaches the band where noisy pixels fall.
  EXPECT_GT(fast.filled_share(), 5 * occupied);
}

}  // namespace
}  // namespace chromo::estimation
