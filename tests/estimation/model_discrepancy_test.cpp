// The model's learned discrepancy (estimation/model_discrepancy.hpp) and the
// estimator on real skin spectra held out by subject (issue 37): the shipped
// residuals are a refit of the shipped spectra, the statistic is sane, and on
// held-out subjects the learned statistic flags little real skin while ink
// and marker stay flagged and σ covers the reference parameters.
#include "chromo/estimation/model_discrepancy.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "six_led_noisy_set.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::estimation {
namespace {

TEST(ModelDiscrepancy, ShippedResidualsAreARefitOfTheShippedSpectra) {
  const auto& spectra = nist_forearm_spectra();
  const auto& shipped = nist_forearm_residuals();
  ASSERT_EQ(spectra.size(), 50u);
  ASSERT_EQ(shipped.size(), 50u);
  const std::vector<NamedSpectrum> some{spectra[0], spectra[24], spectra[49]};
  const auto refit = fit_residuals(some, {}, 2);
  for (std::size_t k = 0; k < some.size(); ++k) {
    const SpectrumResidual& stored = *std::find_if(shipped.begin(), shipped.end(), [&](const auto& r) { return r.name == some[k].name; });
    EXPECT_LT((refit[k].residual.values() - stored.residual.values()).abs().maxCoeff(), 5e-4) << some[k].name;
    EXPECT_LT(((refit[k].fitted.values() - stored.fitted.values()) / stored.fitted.values()).abs().maxCoeff(), 2e-3);
  }
}

TEST(ModelDiscrepancy, StatisticIsShrunkAndPositiveInAnyPlan) {
  const auto d = ModelDiscrepancy::standard();
  EXPECT_EQ(d->subjects(), 50);
  EXPECT_GT(d->shrinkage(), 0.0);
  EXPECT_LT(d->shrinkage(), 1.0);
  // The 4D model's shortfall on real forearms: about 0.01 albedo over the colour band.
  const spectral::Spectrum sigma = d->sigma();
  EXPECT_GT(sigma[14], 0.002);  // 450 nm
  EXPECT_LT(sigma[44], 0.05);   // 600 nm
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  const MeasurementSet method = method_measurement_set(camera, spectral::led_d65_metamer(), spectral::led_spectrum(spectral::LedType::kBlue));
  const Eigen::MatrixXd c = d->channel_covariance(method);
  ASSERT_EQ(c.rows(), 4);
  EXPECT_LT((c - c.transpose()).cwiseAbs().maxCoeff(), 1e-15);
  const Eigen::VectorXd eigen = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(c).eigenvalues();
  EXPECT_GT(eigen.minCoeff(), 0.0);
  for (int k = 0; k < 4; ++k) EXPECT_LT(std::sqrt(c(k, k)), 0.1);
}

TEST(ModelDiscrepancy, LearnRefusesTooFewAndCsvRoundTrips) {
  const auto& shipped = nist_forearm_residuals();
  EXPECT_THROW(ModelDiscrepancy::learn(std::span(shipped).first(2)), std::invalid_argument);
  const std::string csv = residuals_csv(std::span(shipped).first(3), "test");
  const auto parsed = parse_residuals_csv(csv, "round trip");
  ASSERT_EQ(parsed.size(), 3u);
  EXPECT_EQ(parsed[1].name, shipped[1].name);
  EXPECT_LT((parsed[1].residual.values() - shipped[1].residual.values()).abs().maxCoeff(), 1e-5);
  EXPECT_THROW(parse_residuals_csv("wavelength_nm,fitted_a,residual_a\n380,0.1,0.0\n", "short"), std::invalid_argument);
}

// Held-out real skin: the discrepancy learned from subjects whose index is
// not 4 mod 5, the scene's skin the ten that are, six LED types one at a
// time, four frames of a 40,000 e⁻ sensor.
struct HeldOut {
  MeasurementSet set;
  std::shared_ptr<const ForwardTable> table;
  std::shared_ptr<const ModelDiscrepancy> learned;
  std::vector<spectral::Spectrum> test;
};

const HeldOut& held_out() {
  static const HeldOut h = [] {
    HeldOut out;
    out.set = test::six_led_noisy_set();
    out.table = std::make_shared<const ForwardTable>(ForwardTable::build(out.set, TableGrid{}, 2));
    std::vector<SpectrumResidual> train;
    for (std::size_t i = 0; i < nist_forearm_residuals().size(); ++i)
      (i % 5 == 4 ? (void)out.test.push_back(nist_forearm_spectra()[i].albedo) : train.push_back(nist_forearm_residuals()[i]));
    out.learned = std::make_shared<const ModelDiscrepancy>(ModelDiscrepancy::learn(train));
    return out;
  }();
  return h;
}

struct Shares {
  double skin = 0, ink = 0, marker = 0, within_2sigma_cm = 0, within_2sigma_ch = 0;
};

Shares flagged_shares(bool real_skin, std::shared_ptr<const ModelDiscrepancy> discrepancy, std::uint64_t seed) {
  const HeldOut& h = held_out();
  simulators::SyntheticOptions o;
  o.seed = seed;
  o.pixels = 2000;
  o.noise.noise_scale = 0;
  o.share[static_cast<int>(simulators::SyntheticKind::kTattoo)] = 0.05;
  o.share[static_cast<int>(simulators::SyntheticKind::kMarker)] = 0.05;
  if (real_skin) o.skin_spectra = h.test, o.patch_pixels = 200;
  MeasurementSet render = h.set;
  const simulators::SyntheticFrame frame = simulators::make_synthetic_frame(render, o);
  const std::vector<float> noisy = simulators::add_channel_noise(frame.clean, h.set, seed * 31 + 7);
  EstimatorOptions options;
  options.threads = 2;
  options.discrepancy = std::move(discrepancy);
  const Estimator estimator(h.table, h.set, options);
  std::vector<PixelEstimate> e(frame.pixels());
  estimator.estimate(noisy, e);
  std::size_t n[3] = {}, f[3] = {}, explained = 0, cm_in = 0, ch_in = 0;
  for (std::size_t i = 0; i < e.size(); ++i) {
    const int k = frame.kind[i] == simulators::SyntheticKind::kSkin ? 0 : frame.kind[i] == simulators::SyntheticKind::kTattoo ? 1 : 2;
    ++n[k];
    const bool flagged = e[i].flag != PixelFlag::kExplained;
    f[k] += flagged;
    if (k == 0 && !flagged && !real_skin) {
      ++explained;
      cm_in += std::abs(e[i].parameters.cm - frame.truth[i].cm) <= 2 * e[i].sigma[0];
      ch_in += std::abs(e[i].parameters.ch - frame.truth[i].ch) <= 2 * e[i].sigma[1];
    }
  }
  Shares s{double(f[0]) / n[0], double(f[1]) / n[1], double(f[2]) / n[2]};
  if (explained) s.within_2sigma_cm = double(cm_in) / explained, s.within_2sigma_ch = double(ch_in) / explained;
  return s;
}

TEST(RealSkin, LearnedDiscrepancyStopsFlaggingHeldOutRealSkin) {
  const Shares today = flagged_shares(true, nullptr, 3);
  const Shares learned = flagged_shares(true, held_out().learned, 3);
  EXPECT_GT(today.skin, 0.05);   // the model's shortfall taken for noise: ordinary skin flagged
  EXPECT_LE(learned.skin, 0.01);
  EXPECT_GE(learned.ink, 0.95);
  EXPECT_GE(learned.marker, 0.95);
}

// Per pixel (no spatial pass): ink over dark model skin can look like more
// melanin within the discrepancy (real_skin_bench: tattoo 92-100% per fold);
// Ch's σ covers 86-90% of model skin's truth (docs/estimation.md "Real skin").
TEST(RealSkin, ModelSkinKeepsItsFlagsAndSigmaCoversTheTruth) {
  const Shares s = flagged_shares(false, held_out().learned, 5);
  EXPECT_LE(s.skin, 0.01);
  EXPECT_GE(s.ink, 0.85);
  EXPECT_GE(s.marker, 0.95);
  EXPECT_GE(s.within_2sigma_cm, 0.9);
  EXPECT_GE(s.within_2sigma_ch, 0.8);
}

}  // namespace
}  // namespace chromo::estimation
