// The parameter prior learned from real skin (parameter_prior.hpp) and the
// estimator's maximum a posteriori fit with it (estimator.hpp step 4b).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/parameter_prior.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "estimation_fixture.hpp"

namespace chromo::estimation {
namespace {

std::vector<SkinParameters> spread_sets() {
  std::vector<SkinParameters> out;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n;
  for (int i = 0; i < 40; ++i)
    out.push_back({0.05 * std::exp(0.3 * n(rng)), 0.02 * std::exp(0.4 * n(rng)), std::clamp(0.6 + 0.15 * n(rng), 0.0, 1.0),
                   std::clamp(0.01 + 0.004 * n(rng), 0.0, 0.1)});
  return out;
}

TEST(ParameterPrior, LearnsTheMeanAndSpreadInLogsAndRefusesBadInput) {
  const std::vector<SkinParameters> sets = spread_sets();
  const ParameterPrior prior = ParameterPrior::learn(sets);
  Eigen::Vector4d mean = Eigen::Vector4d::Zero();
  for (const auto& p : sets) mean += ParameterPrior::coordinates(p) / static_cast<double>(sets.size());
  EXPECT_LT((prior.mean() - mean).norm(), 1e-12);
  // The variances are the sample's (the shrinkage moves the correlations only).
  for (int k = 0; k < 4; ++k) {
    double variance = 0;
    for (const auto& p : sets) variance += std::pow(ParameterPrior::coordinates(p)(k) - mean(k), 2) / (sets.size() - 1);
    EXPECT_NEAR(prior.covariance()(k, k), variance, 1e-9 * variance) << k;
  }
  EXPECT_NEAR(std::sqrt(prior.covariance()(0, 0)), 0.3, 0.1);  // ln Cm's spread, drawn 0.3
  EXPECT_GE(prior.shrinkage(), 0.0);
  EXPECT_LE(prior.shrinkage(), 1.0);
  const SkinParameters at_mean{std::exp(mean(0)), std::exp(mean(1)), mean(2), mean(3)};
  EXPECT_NEAR(prior.penalty(at_mean), 0.0, 1e-12);
  SkinParameters off = at_mean;
  off.cm *= std::exp(0.3);
  const ParameterPrior wide = ParameterPrior::learn(sets, 2.0);
  EXPECT_NEAR(wide.penalty(off), prior.penalty(off) / 4, 1e-9 * prior.penalty(off));
  EXPECT_THROW(ParameterPrior::learn(std::span(sets).first(4)), std::invalid_argument);
  std::vector<SkinParameters> bad = sets;
  bad[7].ch = 0;
  EXPECT_THROW(ParameterPrior::learn(bad), std::invalid_argument);
  EXPECT_THROW(ParameterPrior::learn(sets, 0.5), std::invalid_argument);
  EstimatorOptions options;
  options.prior_max_channels = 0;
  std::string error;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("prior_max_channels"), std::string::npos) << error;
}

// With the method's four channels the data barely fix βm and Che: on skin
// drawn from the prior's own population, the maximum a posteriori fit lands
// nearer the truth than the maximum-likelihood fit, flags and orders stay
// the data's, and βm's σ narrows.
TEST(ParameterPrior, OnSkinOfItsPopulationTheEstimateMovesTowardsTheTruth) {
  const std::vector<SkinParameters> population = spread_sets();
  const auto prior = std::make_shared<const ParameterPrior>(ParameterPrior::learn(population));
  const MeasurementSet set = testing::method_set();
  const auto table = testing::method_table();
  const SkinModel model;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n;
  std::vector<SkinParameters> truth;
  std::vector<float> measured;
  const std::vector<SkinParameters> draws = [] {
    std::vector<SkinParameters> out;
    std::mt19937_64 r(17);
    std::normal_distribution<double> g;
    for (int i = 0; i < 300; ++i)
      out.push_back({0.05 * std::exp(0.3 * g(r)), 0.02 * std::exp(0.4 * g(r)), std::clamp(0.6 + 0.15 * g(r), 0.0, 1.0),
                     std::clamp(0.01 + 0.004 * g(r), 0.0, 0.1)});
    return out;
  }();
  const Eigen::MatrixXd weights = set.weights();
  for (const SkinParameters& p : draws) {
    const Eigen::VectorXd clean = weights * model.albedo(p).values().matrix();
    truth.push_back(p);
    for (int c = 0; c < set.size(); ++c)
      measured.push_back(static_cast<float>(clean(c) + std::sqrt(set.channels[c].noise.variance(clean(c))) * n(rng)));
  }
  EstimatorOptions without;
  without.threads = 2;
  EstimatorOptions with = without;
  with.prior = prior;
  std::vector<PixelEstimate> ml(draws.size()), map(draws.size());
  Estimator(table, set, without).estimate(measured, ml);
  Estimator(table, set, with).estimate(measured, map);
  double error_ml = 0, error_map = 0, sigma_ml = 0, sigma_map = 0;
  std::size_t changed = 0;
  for (std::size_t i = 0; i < draws.size(); ++i) {
    ASSERT_EQ(ml[i].flag, map[i].flag) << i;
    ASSERT_EQ(ml[i].order, map[i].order) << i;
    EXPECT_EQ(ml[i].chi2, map[i].chi2) << i;
    if (ml[i].flag != PixelFlag::kExplained || ml[i].order != 4) continue;
    ++changed;
    error_ml += std::abs(ml[i].parameters.bm - truth[i].bm) + std::abs(std::log(ml[i].parameters.ch / truth[i].ch));
    error_map += std::abs(map[i].parameters.bm - truth[i].bm) + std::abs(std::log(map[i].parameters.ch / truth[i].ch));
    sigma_ml += ml[i].sigma[2], sigma_map += map[i].sigma[2];
  }
  ASSERT_GT(changed, 150u);
  EXPECT_LT(error_map, 0.8 * error_ml) << "mean |βm error| + |ln Ch error|: " << error_ml / changed << " → "
                                       << error_map / changed;
  EXPECT_LT(sigma_map, 0.8 * sigma_ml);
}

}  // namespace
}  // namespace chromo::estimation
