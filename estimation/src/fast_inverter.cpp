// FastInverter (inverter.hpp): the pre-solved inverse table path, and the
// node-bucket search it falls back to.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "chromo/estimation/inverse_table.hpp"
#include "chromo/estimation/inverter.hpp"
#include "spd_solve.hpp"

namespace chromo::estimation {

FastInverter::FastInverter(std::shared_ptr<const ForwardTable> table, const std::filesystem::path& cache_dir)
    : Inverter(table) {
  inverse_ = InverseTable::load_or_build(table_, cache_dir.empty() ? ForwardTable::default_cache_dir() : cache_dir);
  init();
}

FastInverter::FastInverter(std::shared_ptr<const ForwardTable> table, std::shared_ptr<const InverseTable> inverse)
    : Inverter(std::move(table)), inverse_(std::move(inverse)) {
  init();
}

void FastInverter::init() {
  const ForwardTable& t = *table_;
  const int channels = t.channels();
  const std::vector<std::uint32_t>& nodes = inverse_->bucket_nodes();
  bucket_values_.resize(nodes.size() * channels);
  for (std::size_t i = 0; i < nodes.size(); ++i)
    std::copy_n(t.values().data() + std::size_t(nodes[i]) * channels, channels, bucket_values_.data() + i * channels);
  step_[0] = t.node_offset(1, 0, 0, 0), step_[1] = t.node_offset(0, 1, 0, 0);
  step_[2] = t.node_offset(0, 0, 1, 0), step_[3] = t.node_offset(0, 0, 0, 1);
  presolved_ = channels == 4 && inverse_->branch_count() > 0;
}

double FastInverter::filled_share() const { return inverse_->filled_share(); }

GridPoint FastInverter::seed_point(std::uint32_t node) const {
  const auto n = table_->nodes();
  const std::uint32_t i_ch = node % n[1], i_cm = node / n[1] % n[0], i_che = node / (n[1] * n[0]) % n[3],
                      i_bm = node / (n[1] * n[0] * n[3]);
  return {double(i_cm), double(i_ch), double(i_bm), double(i_che)};
}

namespace {
using Float8 = float __attribute__((vector_size(32)));
}  // namespace

// The 16 corners of the cell around x: along Ch the two corners are adjacent
// in memory (8 floats), so 8 loads of 8 floats cover the cell. S sums the
// corner values weighted along Cm, βm, Che (not Ch); the value interpolates
// S's two halves along Ch, the Ch derivative is their difference, and the
// other derivatives sum Ch-weighted values with one axis' factor replaced by ∓1.
void FastInverter::predict4(const float* x, float* value, float* jacobian) const {
  const auto n = table_->nodes();
  int base[4];
  float f[4];
  for (int k = 0; k < 4; ++k) {
    const float xc = std::clamp(x[k] == x[k] ? x[k] : 0.0f, 0.0f, static_cast<float>(n[k] - 1));
    base[k] = std::min(static_cast<int>(xc), n[k] - 2);
    f[k] = xc - static_cast<float>(base[k]);
  }
  const float* origin = table_->node(base[0], base[1], base[2], base[3]);
  const Float8 ch_weight = {1 - f[1], 1 - f[1], 1 - f[1], 1 - f[1], f[1], f[1], f[1], f[1]};
  Float8 s = {}, d_cm = {}, d_bm = {}, d_che = {};
  for (int corner = 0; corner < 8; ++corner) {
    const bool up_cm = corner & 1, up_bm = corner & 2, up_che = corner & 4;
    const float w_cm = up_cm ? f[0] : 1 - f[0], w_bm = up_bm ? f[2] : 1 - f[2], w_che = up_che ? f[3] : 1 - f[3];
    const float* p = origin + (up_cm ? step_[0] : 0) + (up_bm ? step_[2] : 0) + (up_che ? step_[3] : 0);
    Float8 v;
    std::memcpy(&v, p, sizeof v);
    s += (w_cm * w_bm * w_che) * v;
    if (jacobian) {
      const Float8 along_ch = v * ch_weight;
      d_cm += ((up_cm ? 1.0f : -1.0f) * w_bm * w_che) * along_ch;
      d_bm += ((up_bm ? 1.0f : -1.0f) * w_cm * w_che) * along_ch;
      d_che += ((up_che ? 1.0f : -1.0f) * w_cm * w_bm) * along_ch;
    }
  }
  for (int c = 0; c < 4; ++c) value[c] = (1 - f[1]) * s[c] + f[1] * s[c + 4];
  if (jacobian)
    for (int c = 0; c < 4; ++c) {
      jacobian[c * 4 + 0] = d_cm[c] + d_cm[c + 4];
      jacobian[c * 4 + 1] = s[c + 4] - s[c];
      jacobian[c * 4 + 2] = d_bm[c] + d_bm[c + 4];
      jacobian[c * 4 + 3] = d_che[c] + d_che[c + 4];
    }
}

bool FastInverter::fit_presolved(const double* measured, const double* weight, Fit& fit) const {
  float m[4];
  for (int c = 0; c < 4; ++c) m[c] = static_cast<float>(measured[c]);
  const std::uint32_t cell_index = inverse_->cell_of(m);
  if (cell_index == InverseTable::kNoCell) return false;
  const InverseTable::Cell& cell = inverse_->cell(cell_index);
  const auto n = table_->nodes();
  const float upper[4] = {float(n[0] - 1), float(n[1] - 1), float(n[2] - 1), float(n[3] - 1)};
  // The current point with its prediction and Jacobian (the next step needs both).
  struct Point {
    float x[4], predicted[4], jacobian[16];
    double chi2 = std::numeric_limits<double>::infinity();
  };
  auto evaluate = [&](Point& p) {
    predict4(p.x, p.predicted, p.jacobian);
    p.chi2 = 0;
    for (int c = 0; c < 4; ++c) {
      const double r = (p.predicted[c] - measured[c]) * weight[c];
      p.chi2 += r * r;
    }
  };
  // Per branch: the linear step, and the branch's own solution where the
  // step overshoots (strongly curved cells). The smallest χ² wins.
  Point best, trial;
  const InverseTable::Branch* branches = inverse_->branches(cell);
  for (std::uint32_t b = 0; b < cell.branch_count && best.chi2 > kConvergedChi2; ++b) {
    const InverseTable::Branch& branch = branches[b];
    for (int k = 0; k < 4; ++k) {
      float step = 0;
      for (int c = 0; c < 4; ++c) step += branch.jinv[k * 4 + c] * (m[c] - branch.m0[c]);
      trial.x[k] = std::clamp(branch.x0[k] + step, 0.0f, upper[k]);
    }
    evaluate(trial);
    if (trial.chi2 < best.chi2) best = trial;
    if (trial.chi2 > kPresolvedAcceptChi2) {
      std::copy_n(branch.x0, 4, trial.x);
      evaluate(trial);
      if (trial.chi2 < best.chi2) best = trial;
    }
  }
  if (!std::isfinite(best.chi2)) return false;
  // Bounded Gauss-Newton on the interpolated table (Newton where no bound is
  // active: four channels, four parameters), with backtracking: the
  // interpolant is only piecewise multilinear.
  bool converged = best.chi2 <= kConvergedChi2;
  int iterations = 0;
  for (; iterations < kNewtonSteps && !converged; ++iterations) {
    double jtj[16] = {}, gradient[4] = {};
    for (int c = 0; c < 4; ++c) {
      const double r = (best.predicted[c] - measured[c]) * weight[c];
      double row[4];
      for (int k = 0; k < 4; ++k) row[k] = best.jacobian[c * 4 + k] * weight[c];
      for (int i = 0; i < 4; ++i) {
        gradient[i] += row[i] * r;
        for (int k = 0; k < 4; ++k) jtj[i * 4 + k] += row[i] * row[k];
      }
    }
    // A coordinate at its bound whose gradient points outward is held.
    for (int k = 0; k < 4; ++k) {
      if ((best.x[k] <= 0 && gradient[k] > 0) || (best.x[k] >= upper[k] && gradient[k] < 0)) {
        for (int i = 0; i < 4; ++i) jtj[k * 4 + i] = jtj[i * 4 + k] = 0;
        jtj[k * 4 + k] = 1, gradient[k] = 0;
      } else {
        jtj[k * 4 + k] *= 1 + 1e-9;
      }
    }
    double step[4];
    detail::solve_spd4(jtj, gradient, step);
    bool improved = false;
    for (float scale = 1.0f; scale > 0.005f && !improved; scale *= 0.5f) {
      float moved = 0;
      for (int k = 0; k < 4; ++k) {
        trial.x[k] = std::clamp(best.x[k] - std::clamp(scale * static_cast<float>(step[k]), -4.0f, 4.0f), 0.0f, upper[k]);
        moved = std::max(moved, std::abs(trial.x[k] - best.x[k]));
      }
      evaluate(trial);
      if (trial.chi2 < best.chi2) {
        converged = trial.chi2 <= kConvergedChi2 || moved < 1e-3f || best.chi2 - trial.chi2 < 1e-4 * best.chi2;
        best = trial, improved = true;
      }
    }
    if (!improved) converged = true;  // no descent along the GN direction: a (bounded) minimum
  }
  fit.x = {best.x[0], best.x[1], best.x[2], best.x[3]};
  fit.chi2 = best.chi2;
  fit.iterations = iterations;
  fit.has_prediction = true;
  std::copy_n(best.predicted, 4, fit.predicted);
  return converged;
}

Fit FastInverter::fit(const double* measured, const double* weight, int order) const {
  return fit(measured, weight, order, nullptr);
}

Fit FastInverter::fit(const double* measured, const double* weight, int order, FastPath* path) const {
  Fit presolved;
  presolved.chi2 = std::numeric_limits<double>::infinity();
  if (order == 4 && presolved_) {
    const bool converged = fit_presolved(measured, weight, presolved);
    if (converged && presolved.chi2 <= kPresolvedAcceptChi2) {
      if (path) *path = FastPath::kPresolved;
      return presolved;
    }
  }
  if (path) *path = FastPath::kSearched;
  const Fit searched = fit_by_search(measured, weight, order);
  return searched.chi2 <= presolved.chi2 ? searched : presolved;
}

Fit FastInverter::fit_by_search(const double* measured, const double* weight, int order) const {
  float m[kMaxChannels], w[kMaxChannels];
  const int channels = table_->channels();
  for (int c = 0; c < channels; ++c) m[c] = static_cast<float>(measured[c]), w[c] = static_cast<float>(weight[c]);
  const std::uint32_t cell_index = inverse_->cell_of(m);
  GridPoint start;
  const bool in_table = cell_index != InverseTable::kNoCell;
  if (in_table) {
    // The best node by χ² among the nodes whose predicted values fall in the
    // pixel's cell: the nodes of every branch of the (non-unique) inverse there.
    const InverseTable::Cell& cell = inverse_->cell(cell_index);
    float best = std::numeric_limits<float>::infinity();
    int best_index = 0;
    scan_nodes(channels, bucket_values_.data() + std::size_t(cell.bucket_begin) * channels,
               static_cast<int>(cell.bucket_count), m, w, best, best_index);
    start = seed_point(inverse_->bucket_nodes()[cell.bucket_begin + best_index]);
  } else {
    start = node_search(measured, weight, 4, 4);  // outside the inverse table: coarse search
  }
  return refine(measured, weight, order, node_descent(measured, weight, order, start, !in_table), 20);
}

}  // namespace chromo::estimation
