// SubspaceInverter (subspace_inverter.hpp): start and Gauss-Newton in the
// plan's 8-D subspace, polish on the full weighted residual.
#include "chromo/estimation/subspace_inverter.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "spd_solve.hpp"

namespace chromo::estimation {

namespace {

constexpr int kDims = SubspaceTable::kDims;
using Float8 = float __attribute__((vector_size(32)));

float distance2(const float* a, const float* b) {
  Float8 va, vb;
  std::memcpy(&va, a, sizeof va);
  std::memcpy(&vb, b, sizeof vb);
  const Float8 d = va - vb, s = d * d;
  return ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]));
}

// The pixel's own diagonal weights in the subspace. With y the whitened
// channels, U the stored axes (C × 8), D = diag(weight_c · σ_ref,c) and r⊥ the
// measurement's part off the subspace (the table's own is negligible,
// SubspaceTable::off_subspace_rms()), the full weighted χ² at x is
//   |D (U (z_x − z_m) − r⊥)|² = |Lᵀ z_x − target|² + const,
// M = Uᵀ D² U = L Lᵀ, b = Uᵀ D² r⊥, target = Lᵀ z_m + L⁻¹ b: an 8-D problem
// whose set-up is O(C) once per pixel.
struct PixelMetric {
  float lt[kDims * kDims];  // Lᵀ, row-major
  float target[kDims];
};

bool pixel_metric(const SubspaceTable& table, const double* measured, const double* weight, const float* z,
                  PixelMetric& out) {
  const int channels = table.channels(), kept = table.kept_dims();
  ChannelBuffer<float> y(channels);
  table.whiten(measured, y);
  Eigen::Matrix<double, kDims, kDims> m = Eigen::Matrix<double, kDims, kDims>::Zero();
  Eigen::Matrix<double, kDims, 1> b = Eigen::Matrix<double, kDims, 1>::Zero();
  const std::vector<double>& sigma = table.reference_sigma();
  for (int c = 0; c < channels; ++c) {
    Eigen::Matrix<double, kDims, 1> a = Eigen::Matrix<double, kDims, 1>::Zero();
    double off = y[c];
    for (int k = 0; k < kept; ++k) a(k) = table.axis(k)[c], off -= a(k) * z[k];
    const double rho2 = (weight[c] * sigma[c]) * (weight[c] * sigma[c]);
    m.noalias() += rho2 * a * a.transpose();
    b += (rho2 * off) * a;
  }
  for (int k = kept; k < kDims; ++k) m(k, k) = 1;
  const Eigen::LLT<Eigen::Matrix<double, kDims, kDims>> llt(m);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::Matrix<double, kDims, kDims> lt = llt.matrixU();
  const Eigen::Matrix<double, kDims, 1> c = llt.matrixL().solve(b);
  Eigen::Matrix<double, kDims, 1> zm;
  for (int k = 0; k < kDims; ++k) zm(k) = z[k];
  const Eigen::Matrix<double, kDims, 1> target = lt * zm + c;
  for (int r = 0; r < kDims; ++r) {
    out.target[r] = static_cast<float>(target(r));
    for (int k = 0; k < kDims; ++k) out.lt[r * kDims + k] = static_cast<float>(lt(r, k));
  }
  return std::isfinite(target.sum());
}

// Bounded Gauss-Newton on |Lᵀ P(x) − target|² in the subspace (P:
// SubspaceTable::predict; without a metric |P(x) − z|²) from x, with
// `free_dims` free coordinates (4, or 2 for the 2D slice) and backtracking
// (the interpolant is piecewise multilinear). x is updated.
void subspace_gauss_newton(const SubspaceTable& table, const float* z, const PixelMetric* metric, const float* upper,
                           int free_dims, int steps, float* x) {
  float value[kDims], jacobian[kDims * 4];
  const float* goal = metric ? metric->target : z;
  auto chi2_at = [&](const float* at, bool with_jacobian) {
    float raw[kDims], raw_jacobian[kDims * 4];
    table.predict(at, raw, with_jacobian ? raw_jacobian : nullptr);
    if (!metric) {
      std::copy_n(raw, kDims, value);
      if (with_jacobian) std::copy_n(raw_jacobian, kDims * 4, jacobian);
    } else {
      for (int r = 0; r < kDims; ++r) {
        float v = 0, j[4] = {};
        for (int k = r; k < kDims; ++k) {  // Lᵀ is upper triangular
          const float l = metric->lt[r * kDims + k];
          v += l * raw[k];
          if (with_jacobian)
            for (int q = 0; q < 4; ++q) j[q] += l * raw_jacobian[k * 4 + q];
        }
        value[r] = v;
        if (with_jacobian) std::copy_n(j, 4, jacobian + r * 4);
      }
    }
    return distance2(value, goal);
  };
  double chi2 = chi2_at(x, true);
  float trial[4];
  for (int iteration = 0; iteration < steps && chi2 > 1e-6; ++iteration) {
    double jtj[16] = {}, gradient[4] = {};
    for (int r = 0; r < kDims; ++r) {
      const double residual = value[r] - goal[r];
      const float* row = jacobian + r * 4;
      for (int i = 0; i < 4; ++i) {
        gradient[i] += row[i] * residual;
        for (int k = 0; k < 4; ++k) jtj[i * 4 + k] += double(row[i]) * row[k];
      }
    }
    double step[4];
    const double predicted_gain = detail::bounded_gauss_newton_step(jtj, gradient, x, upper, free_dims, step);
    if (predicted_gain < 1e-4 * chi2) break;
    bool improved = false;
    for (float scale = 1.0f; scale > 0.005f && !improved; scale *= 0.5f) {
      float moved = 0;
      for (int k = 0; k < 4; ++k) {
        trial[k] = std::clamp(x[k] - std::clamp(scale * static_cast<float>(step[k]), -4.0f, 4.0f), 0.0f, upper[k]);
        moved = std::max(moved, std::abs(trial[k] - x[k]));
      }
      const double trial_chi2 = chi2_at(trial, true);
      if (trial_chi2 < chi2) {
        const bool stalled = moved < 1e-3f || chi2 - trial_chi2 < 1e-4 * chi2;
        std::copy_n(trial, 4, x), chi2 = trial_chi2, improved = true;
        if (stalled) return;
      }
    }
    if (!improved) return;
    // chi2_at(trial) left value and jacobian at the accepted point.
  }
}

}  // namespace

bool SubspaceInverterOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (subspace_steps < 0 || subspace_steps > 1000) return fail("subspace_steps must be in 0..1000");
  if (polish_steps < 0 || polish_steps > 1000) return fail("polish_steps must be in 0..1000");
  if (!(fallback_chi2 >= 0)) return fail("fallback_chi2 must be >= 0");
  return true;
}

SubspaceInverter::SubspaceInverter(std::shared_ptr<const ForwardTable> table, std::shared_ptr<const SubspaceTable> subspace,
                                   std::shared_ptr<const InverseTable> inverse, Options options)
    : Inverter(std::move(table)), options_(options), subspace_(std::move(subspace)), inverse_(std::move(inverse)) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("subspace inverter options: " + error);
  if (!subspace_ || subspace_->forward().key() != table_->key() || subspace_->channels() != table_->channels())
    throw std::invalid_argument("subspace inverter: the subspace table was not built on this forward table");
  if (!inverse_ || inverse_->key_channels() != table_->channels())
    throw std::invalid_argument("subspace inverter: the inverse table does not match the forward table's channels");
  const auto n = table_->nodes();
  for (int i_bm = 0; i_bm < n[2]; i_bm += 4)
    for (int i_che = 0; i_che < n[3]; i_che += 4)
      for (int i_cm = 0; i_cm < n[0]; i_cm += 8)
        for (int i_ch = 0; i_ch < n[1]; i_ch += 8) coarse_nodes_.push_back({i_cm, i_ch, i_bm, i_che});
  coarse_z_.resize(coarse_nodes_.size() * kDims);
  for (std::size_t i = 0; i < coarse_nodes_.size(); ++i) {
    const auto& at = coarse_nodes_[i];
    std::copy_n(subspace_->node(subspace_->node_index(at[0], at[1], at[2], at[3])), kDims, coarse_z_.data() + i * kDims);
  }
}

std::array<int, 4> SubspaceInverter::coarse_scan(const float* z) const {
  // Level 1: the coarse nodes; level 2: the half-way nodes around the best one.
  float best = std::numeric_limits<float>::infinity();
  std::size_t best_index = 0;
  for (std::size_t i = 0; i < coarse_nodes_.size(); ++i) {
    const float d = distance2(coarse_z_.data() + i * kDims, z);
    if (d < best) best = d, best_index = i;
  }
  const auto n = table_->nodes();
  const std::array<int, 4> centre = coarse_nodes_[best_index];
  std::array<int, 4> at = centre;
  const int half[4] = {4, 4, 2, 2};
  for (int code = 0; code < 81; ++code) {
    std::array<int, 4> node;
    bool inside = true;
    for (int d = 0, rest = code; d < 4; ++d, rest /= 3) {
      node[d] = centre[d] + (rest % 3 - 1) * half[d];
      inside = inside && node[d] >= 0 && node[d] < n[d];
    }
    if (!inside) continue;
    const float d = distance2(subspace_->node(subspace_->node_index(node[0], node[1], node[2], node[3])), z);
    if (d < best) best = d, at = node;
  }
  return at;
}

std::array<int, 4> SubspaceInverter::start_node(const float* z, const double* measured) const {
  const int channels = table_->channels();
  ChannelBuffer<float> m(channels);
  for (int c = 0; c < channels; ++c) m[c] = static_cast<float>(measured[c]);
  const std::uint32_t cell_index = inverse_->cell_of(m);
  if (cell_index == InverseTable::kNoCell) return coarse_scan(z);
  const InverseTable::Cell& cell = inverse_->cell(cell_index);
  const std::uint32_t* bucket = inverse_->bucket_nodes().data() + cell.bucket_begin;
  float best = std::numeric_limits<float>::infinity();
  std::uint32_t best_node = bucket[0];
  for (std::uint32_t i = 0; i < cell.bucket_count; ++i) {
    const float d = distance2(subspace_->node(bucket[i]), z);
    if (d < best) best = d, best_node = bucket[i];
  }
  const GridPoint start = node_point(best_node);
  return {int(start[0]), int(start[1]), int(start[2]), int(start[3])};
}

std::array<int, 4> SubspaceInverter::descend_nodes(const float* z, std::array<int, 4> at, int dims, bool diagonal) const {
  const auto n = table_->nodes();
  auto chi2_of = [&](const std::array<int, 4>& i) {
    return distance2(subspace_->node(subspace_->node_index(i[0], i[1], i[2], i[3])), z);
  };
  float best = chi2_of(at);
  const int full = dims == 4 ? 81 : 9;
  for (int step = 0; step < 96; ++step) {
    std::array<int, 4> best_move = at;
    for (int d = 0; d < dims; ++d)
      for (int delta : {-1, 1}) {
        std::array<int, 4> candidate = at;
        candidate[d] += delta;
        if (candidate[d] < 0 || candidate[d] >= n[d]) continue;
        const float chi2 = chi2_of(candidate);
        if (chi2 < best) best = chi2, best_move = candidate;
      }
    if (best_move == at) {
      if (!diagonal) break;
      for (int k = 0; k < full; ++k) {
        std::array<int, 4> candidate = at;
        bool inside = true;
        for (int d = 0, code = k; d < dims; ++d, code /= 3) {
          candidate[d] += code % 3 - 1;
          inside = inside && candidate[d] >= 0 && candidate[d] < n[d];
        }
        if (!inside) continue;
        const float chi2 = chi2_of(candidate);
        if (chi2 < best) best = chi2, best_move = candidate;
      }
      if (best_move == at) break;
    }
    at = best_move;
  }
  return at;
}

Fit SubspaceInverter::search_full(const double* measured, const double* weight, int order) const {
  // The fast inverter's search path (Inverter::search_bucket) in the full
  // channel space; outside the inverse table the subspace's node scan.
  return search_bucket(*inverse_, nullptr, measured, weight, order, [&] {
    float z[kDims];
    subspace_->project(measured, z);
    const auto at = coarse_scan(z);
    return GridPoint{double(at[0]), double(at[1]), double(at[2]), double(at[3])};
  });
}

Fit SubspaceInverter::fit(const double* measured, const double* weight, int order) const {
  const int free_dims = order == 4 ? 4 : 2;
  const auto n = table_->nodes();
  const float upper[4] = {float(n[0] - 1), float(n[1] - 1), float(n[2] - 1), float(n[3] - 1)};
  float z[kDims];
  subspace_->project(measured, z);
  std::array<int, 4> at = start_node(z, measured);
  if (free_dims == 2) {
    // The 2D slice: the 4D start's Cm and Ch on it, or the best of a coarse
    // scan of the slice (every 4th node), whichever is closer.
    const int bm_2d = static_cast<int>(std::lround(bm_2d_coordinate()));
    at[2] = bm_2d, at[3] = 0;
    float best = distance2(subspace_->node(subspace_->node_index(at[0], at[1], at[2], at[3])), z);
    for (int i_cm = 0; i_cm < n[0]; i_cm += 4)
      for (int i_ch = 0; i_ch < n[1]; i_ch += 4) {
        const float d = distance2(subspace_->node(subspace_->node_index(i_cm, i_ch, bm_2d, 0)), z);
        if (d < best) best = d, at = {i_cm, i_ch, bm_2d, 0};
      }
  }
  at = descend_nodes(z, at, free_dims, free_dims == 2);
  // Off the node by a parabola through its two axis neighbours' χ² per axis
  // (at a node the multilinear Jacobian is one-sided: Gauss-Newton started
  // there often found no descent towards the lower side).
  float x[4] = {float(at[0]), float(at[1]), float(at[2]), float(at[3])};
  const float centre = distance2(subspace_->node(subspace_->node_index(at[0], at[1], at[2], at[3])), z);
  for (int k = 0; k < free_dims; ++k) {
    if (at[k] == 0 || at[k] == n[k] - 1) continue;
    std::array<int, 4> below = at, above = at;
    --below[k], ++above[k];
    const float lo = distance2(subspace_->node(subspace_->node_index(below[0], below[1], below[2], below[3])), z);
    const float hi = distance2(subspace_->node(subspace_->node_index(above[0], above[1], above[2], above[3])), z);
    const float curvature = lo - 2 * centre + hi;
    if (curvature > 0) x[k] += std::clamp(0.5f * (lo - hi) / curvature, -0.5f, 0.5f);
  }
  if (free_dims == 2) x[2] = static_cast<float>(bm_2d_coordinate()), x[3] = 0;
  PixelMetric metric;
  const bool weighted = pixel_metric(*subspace_, measured, weight, z, metric);
  subspace_gauss_newton(*subspace_, z, weighted ? &metric : nullptr, upper, free_dims, options_.subspace_steps, x);

  // Polish on the full weighted residual (the pixel's own weights).
  Fit fit = refine(measured, weight, order, GridPoint{x[0], x[1], x[2], x[3]}, options_.polish_steps);
  // Order 2 as the fast inverter: a 2D fit above the threshold is a pixel
  // the 2D model does not explain, no search.
  if (free_dims == 4 && fit.chi2 > options_.fallback_chi2) {
    const Fit searched = search_full(measured, weight, order);
    if (searched.chi2 < fit.chi2) fit = searched;
  }
  return fit;
}

}  // namespace chromo::estimation
