// The relit layer's posterior discrepancy (estimation/discrepancy_posterior.hpp):
// the NIST forearms' residuals of held-out subjects estimated from their
// channels, its limits (no information: μ_d; exact channels: the channels
// reproduced) and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "chromo/estimation/discrepancy_posterior.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/grid.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::estimation {
namespace {

MeasurementSet six_led_set() {
  std::vector<std::pair<std::string, spectral::Spectrum>> leds;
  for (auto type : spectral::kAllLedTypes) leds.emplace_back(std::string(spectral::led_type_name(type)), spectral::led_spectrum(type));
  return simulators::capture_measurement_set(spectral::builtin_camera("nikon_d5100"), leds);
}

// RMS over 430-680 nm, where the relit colours are formed.
double rms_visible(const spectral::GridArray& a) {
  double sum = 0;
  int n = 0;
  for (int k = 0; k < spectral::kGridSize; ++k)
    if (spectral::grid_wavelength_nm(k) >= 430 && spectral::grid_wavelength_nm(k) <= 680) sum += a[k] * a[k], ++n;
  return std::sqrt(sum / n);
}

std::vector<double> channels_of(const Eigen::MatrixXd& w, const spectral::Spectrum& s) {
  const Eigen::VectorXd v = w * s.values().matrix();
  return {v.data(), v.data() + v.size()};
}

TEST(DiscrepancyPosterior, MeanResidualIsTheTrainingResidualsMean) {
  const auto& all = nist_forearm_residuals();
  const ModelDiscrepancy d = ModelDiscrepancy::learn(all);
  spectral::GridArray mean = spectral::GridArray::Zero();
  for (const auto& r : all) mean += r.residual.values();
  mean /= static_cast<double>(all.size());
  EXPECT_LT((d.mean_residual().values() - mean).abs().maxCoeff(), 1e-12);
  // Σ_d about the mean is smaller on the diagonal than Σ_r about zero by μ_d² (up to n/(n−1)).
  const int k550 = static_cast<int>((550 - spectral::kGridStartNm) / spectral::kGridStepNm);
  EXPECT_LT(d.centred_covariance()(k550, k550), d.covariance()(k550, k550));
}

TEST(DiscrepancyPosterior, LimitsAreTheMeanWithoutInformationAndTheChannelsWithExactOnes) {
  const MeasurementSet set = six_led_set();
  const Eigen::MatrixXd w = set.weights();
  const ModelDiscrepancy d = ModelDiscrepancy::learn(nist_forearm_residuals());
  const DiscrepancyPosterior centred(d, set, DiscrepancyPrior::kMeanAndCovariance);
  const DiscrepancyPosterior zero_mean(d, set);  // the default
  ASSERT_EQ(centred.channels(), 18);
  const std::vector<double> residual = channels_of(w, nist_forearm_residuals()[7].residual);
  const std::vector<double> no_information(18, 1e6), exact_channels(18, 1e-12);
  EXPECT_LT((centred.mean(residual, no_information).values() - d.mean_residual().values()).abs().maxCoeff(), 1e-6);
  EXPECT_LT(zero_mean.mean(residual, no_information).values().abs().maxCoeff(), 1e-6);
  // A pixel its fit explains exactly (skin the model renders): the zero-mean prior adds nothing, μ_d's prior
  // adds what the channels cannot see of μ_d.
  const std::vector<double> none(18, 0.0);
  EXPECT_EQ(zero_mean.mean(none, exact_channels).values().abs().maxCoeff(), 0.0);
  EXPECT_GT(centred.mean(none, exact_channels).values().abs().maxCoeff(), 1e-3);
  for (const DiscrepancyPosterior* posterior : {&centred, &zero_mean}) {
    const std::vector<double> seen = channels_of(w, posterior->mean(residual, exact_channels));
    for (int c = 0; c < 18; ++c) EXPECT_NEAR(seen[c], residual[c], 1e-6) << set.channels[c].name;
  }
}

// Held out by subject (5 folds, learned on the other 40): the posterior from
// the six LEDs' 18 channels (noise of 0.001 albedo per channel) against μ_d
// alone, RMS error against the subject's own residual over 430-680 nm,
// averaged over the 50 subjects. Measured: 0.00438 (μ_d) → 0.00207 (posterior, zero-mean prior).
TEST(DiscrepancyPosterior, HeldOutSubjectsResidualsAreCloserThanTheMean) {
  const MeasurementSet set = six_led_set();
  const Eigen::MatrixXd w = set.weights();
  const auto& all = nist_forearm_residuals();
  double with_mean = 0, with_posterior = 0;
  for (int fold = 0; fold < 5; ++fold) {
    std::vector<SpectrumResidual> train;
    for (std::size_t i = 0; i < all.size(); ++i)
      if (static_cast<int>(i % 5) != fold) train.push_back(all[i]);
    const ModelDiscrepancy d = ModelDiscrepancy::learn(train);
    const DiscrepancyPosterior posterior(d, set);
    for (std::size_t i = fold; i < all.size(); i += 5) {
      const spectral::Spectrum estimate = posterior.mean(channels_of(w, all[i].residual), std::vector<double>(18, 1e-6));
      with_mean += rms_visible(d.mean_residual().values() - all[i].residual.values()) / all.size();
      with_posterior += rms_visible(estimate.values() - all[i].residual.values()) / all.size();
    }
  }
  EXPECT_LT(with_posterior, 0.7 * with_mean);
}

TEST(DiscrepancyPosterior, BadInputIsRefusedByName) {
  const DiscrepancyPosterior posterior(ModelDiscrepancy::learn(nist_forearm_residuals()), six_led_set());
  EXPECT_THROW(posterior.mean(std::vector<double>(4, 0), std::vector<double>(18, 1e-6)), std::invalid_argument);
  std::vector<double> residual(18, 0), variance(18, 1e-6);
  variance[3] = -1;
  try {
    posterior.mean(residual, variance);
    FAIL() << "a negative variance was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("channel 3"), std::string::npos) << e.what();
  }
  variance[3] = 1e-6;
  residual[5] = std::nan("");
  EXPECT_THROW(posterior.mean(residual, variance), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::estimation
