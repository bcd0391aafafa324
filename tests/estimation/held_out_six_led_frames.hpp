// Frames of held-out NIST subjects (or model skin) with ink and marker under
// the six LED types one at a time, noisy, and the discrepancy learned from
// folds 1-4: shared by the discrepancy-scale and local-bias tests (one table
// build per test binary).
#pragma once

#include <array>
#include <memory>
#include <vector>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "six_led_noisy_set.hpp"

namespace chromo::estimation::test {

// The six LED types one at a time, four frames of a 40,000 e⁻ sensor; the
// discrepancy learned from the subjects of folds 1-4 (index not 0 mod 5),
// so subject_006 (index 5) and subject_011 (index 10) are held out.
struct Plan {
  MeasurementSet set;
  std::shared_ptr<const ForwardTable> table;
  std::shared_ptr<const ModelDiscrepancy> learned;
};

inline const Plan& plan() {
  static const Plan p = [] {
    Plan out;
    out.set = test::six_led_noisy_set();
    out.table = std::make_shared<const ForwardTable>(ForwardTable::build(out.set, TableGrid{}, 2));
    std::vector<SpectrumResidual> train;
    for (std::size_t i = 0; i < nist_forearm_residuals().size(); ++i)
      if (i % 5 != 0) train.push_back(nist_forearm_residuals()[i]);
    out.learned = std::make_shared<const ModelDiscrepancy>(ModelDiscrepancy::learn(train));
    return out;
  }();
  return p;
}

struct Frame {
  simulators::SyntheticFrame truth;
  std::vector<float> noisy;
};

// One subject's frame: `subject`'s spectrum (or model skin for -1) with `ink` tattoo and 5% marker.
inline Frame frame_of(int subject, double ink, std::uint64_t seed) {
  simulators::SyntheticOptions o;
  o.seed = seed;
  o.pixels = 400;
  o.noise.noise_scale = 0;
  o.share[static_cast<int>(simulators::SyntheticKind::kTattoo)] = ink;
  o.share[static_cast<int>(simulators::SyntheticKind::kMarker)] = 0.05;
  if (subject >= 0) o.skin_spectra = {nist_forearm_spectra()[static_cast<std::size_t>(subject)].albedo}, o.patch_pixels = 400;
  MeasurementSet render = plan().set;
  Frame f{simulators::make_synthetic_frame(render, o), {}};
  f.noisy = simulators::add_channel_noise(f.truth.clean, plan().set, seed * 31 + 7);
  return f;
}

inline Estimator learned_estimator() {
  EstimatorOptions options;
  options.threads = 2;
  options.tile_pixels = 128;
  options.discrepancy = plan().learned;
  return Estimator(plan().table, plan().set, options);
}

// Shares flagged of skin, tattoo and marker.
// Shares flagged of skin, tattoo and marker in estimates of f.
inline std::array<double, 3> flagged_shares(const Frame& f, const std::vector<PixelEstimate>& e) {
  std::size_t n[3] = {}, k[3] = {};
  for (std::size_t i = 0; i < e.size(); ++i) {
    const auto kind = f.truth.kind[i];
    const int c = kind == simulators::SyntheticKind::kSkin ? 0 : kind == simulators::SyntheticKind::kTattoo ? 1 : 2;
    ++n[c];
    k[c] += e[i].flag != PixelFlag::kExplained;
  }
  return {n[0] ? double(k[0]) / n[0] : 0, n[1] ? double(k[1]) / n[1] : 0, n[2] ? double(k[2]) / n[2] : 0};
}

inline std::array<double, 3> flagged(const Estimator& estimator, const Frame& f) {
  std::vector<PixelEstimate> e(f.truth.pixels());
  estimator.estimate(f.noisy, e);
  return flagged_shares(f, e);
}

}  // namespace chromo::estimation::test
