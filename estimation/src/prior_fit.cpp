#include "prior_fit.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "chromo/estimation/channel_buffer.hpp"

namespace chromo::estimation::detail {

double GridPrior::penalty(const GridPoint& x) const {
  const Eigen::Vector4d d = Eigen::Map<const Eigen::Vector4d>(x.data()) - mean;
  return d.dot(information * d);
}

GridPrior grid_prior(const ForwardTable& table, const ParameterPrior& prior) {
  const auto nodes = table.nodes();
  Eigen::Vector4d origin, step;
  for (int k = 0; k < 4; ++k) {
    GridPoint at{}, next{}, last{};
    next[k] = 1, last[k] = nodes[k] - 1.0;
    const double u0 = ParameterPrior::coordinates(table.from_grid(at))(k);
    const double u1 = ParameterPrior::coordinates(table.from_grid(next))(k);
    const double un = ParameterPrior::coordinates(table.from_grid(last))(k);
    origin(k) = u0, step(k) = u1 - u0;
    if (!(std::abs(u0 + step(k) * (nodes[k] - 1.0) - un) <= 1e-6 * std::abs(step(k)) * nodes[k]))
      throw std::invalid_argument("grid_prior: grid axis " + std::to_string(k) + " is not affine in the prior's coordinates");
  }
  GridPrior out;
  out.mean = (prior.mean() - origin).cwiseQuotient(step);
  out.information = step.asDiagonal() * prior.information() * step.asDiagonal();
  return out;
}

PriorFit prior_fit(const ForwardTable& table, const PixelCovariance& covariance, const GridPrior& prior,
                   const double* measured, const GridPoint& start) {
  const int c_count = table.channels();
  const auto nodes = table.nodes();
  ChannelBuffer<double> value(c_count), jacobian(c_count * 4), residual(c_count);
  auto clamp = [&](GridPoint x) {
    for (int k = 0; k < 4; ++k) x[k] = std::clamp(x[k], 0.0, nodes[k] - 1.0);
    return x;
  };
  auto evaluate = [&](const GridPoint& x, bool with_jacobian, PriorFit& f) {
    table.predict(x, value.data(), with_jacobian ? jacobian.data() : nullptr);
    for (int c = 0; c < c_count; ++c) residual[c] = value[c] - measured[c];
    f.x = x, f.chi2 = covariance.chi2(residual.data()), f.penalty = prior.penalty(x);
    return f.chi2 + f.penalty;
  };
  auto descend = [&](const GridPoint& from) {
    PriorFit best;
    double cost = evaluate(clamp(from), true, best);
    for (int it = 0; it < kPriorFitIterations; ++it) {
      const Eigen::Map<const Eigen::Vector4d> x(best.x.data());
      const Eigen::Matrix4d h = covariance.information(jacobian.data()) + prior.information;
      const Eigen::Vector4d g = covariance.gradient(jacobian.data(), residual.data()) + prior.information * (x - prior.mean);
      const Eigen::Vector4d step = -h.ldlt().solve(g);
      if (!step.allFinite()) break;
      double scale = 1;
      bool improved = false;
      PriorFit trial;
      for (int halving = 0; halving < 6 && !improved; ++halving, scale *= 0.5) {
        GridPoint next;
        for (int k = 0; k < 4; ++k) next[k] = best.x[k] + scale * step(k);
        const double trial_cost = evaluate(clamp(next), false, trial);
        improved = trial_cost < cost;
        if (improved) {
          const double gain = cost - trial_cost;
          cost = evaluate(trial.x, true, best);  // the Jacobian at the new point
          if (gain < 1e-6 * std::max(cost, 1e-3)) return best;
        }
      }
      if (!improved) break;
    }
    // best is complete (its x, χ² and penalty); the buffers may hold a rejected trial.
    return best;
  };
  const PriorFit from_start = descend(start);
  GridPoint at_mean;
  for (int k = 0; k < 4; ++k) at_mean[k] = prior.mean(k);
  const PriorFit from_mean = descend(at_mean);
  return from_start.chi2 + from_start.penalty <= from_mean.chi2 + from_mean.penalty ? from_start : from_mean;
}

}  // namespace chromo::estimation::detail
