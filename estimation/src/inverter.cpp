#include "chromo/estimation/inverter.hpp"
#include "spd_solve.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace chromo::estimation {

double Inverter::chi2_at(const double* measured, const double* weight, const GridPoint& x) const {
  ChannelBuffer<double> predicted(table_->channels());
  table_->predict(x, predicted);
  double chi2 = 0;
  for (int c = 0; c < table_->channels(); ++c) {
    const double r = (predicted[c] - measured[c]) * weight[c];
    chi2 += r * r;
  }
  return chi2;
}

namespace {

Eigen::Vector4d solve_spd(const Eigen::Matrix4d& a, const Eigen::Vector4d& b) {
  Eigen::Vector4d x;
  detail::solve_spd4(a.data(), b.data(), x.data());
  return x;
}

}  // namespace

void Inverter::interpolate(const GridPoint& x, double* value, double* jacobian) const {
  table_->predict(x, value, jacobian);
}

Fit Inverter::refine(const double* measured, const double* weight, int order, GridPoint x, int max_iterations) const {
  const int channels = table_->channels();
  const auto nodes = table_->nodes();
  const int dims = order == 4 ? 4 : 2;
  if (dims == 2) x[2] = bm_2d_coordinate(), x[3] = 0;
  for (int k = 0; k < 4; ++k) x[k] = std::clamp(x[k], 0.0, nodes[k] - 1.0);

  ChannelBuffer<double> predicted(channels), jacobian(std::size_t(channels) * 4);
  auto evaluate = [&](const GridPoint& at, bool with_jacobian) {
    interpolate(at, predicted, with_jacobian ? jacobian.data() : nullptr);
    double chi2 = 0;
    for (int c = 0; c < channels; ++c) {
      const double r = (predicted[c] - measured[c]) * weight[c];
      chi2 += r * r;
    }
    return chi2;
  };
  Fit fit;
  fit.x = x;
  fit.chi2 = evaluate(x, true);
  double lambda = 1e-3;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    fit.iterations = iteration + 1;
    Eigen::Matrix4d jtj = Eigen::Matrix4d::Zero();
    Eigen::Vector4d jtr = Eigen::Vector4d::Zero();
    for (int c = 0; c < channels; ++c) {
      const double r = (predicted[c] - measured[c]) * weight[c];
      Eigen::Vector4d row;
      for (int k = 0; k < 4; ++k) row[k] = k < dims ? jacobian[c * 4 + k] * weight[c] : 0.0;
      jtj.noalias() += row * row.transpose();
      jtr += row * r;
    }
    // Bounds: a coordinate at its bound whose gradient points outward is held.
    bool active[4];
    for (int k = 0; k < 4; ++k) {
      active[k] = k < dims;
      if (k < dims && ((fit.x[k] <= 0 && jtr[k] > 0) || (fit.x[k] >= nodes[k] - 1 && jtr[k] < 0))) active[k] = false;
    }
    bool accepted = false;
    for (int attempt = 0; attempt < 6 && !accepted; ++attempt) {
      Eigen::Matrix4d a = jtj;
      for (int k = 0; k < 4; ++k) {
        if (!active[k]) {
          a.row(k).setZero(), a.col(k).setZero(), a(k, k) = 1;
        } else {
          a(k, k) += lambda * (jtj(k, k) + 1e-9);
        }
      }
      Eigen::Vector4d g = jtr;
      for (int k = 0; k < 4; ++k)
        if (!active[k]) g[k] = 0;
      const Eigen::Vector4d step = -solve_spd(a, g);
      GridPoint candidate = fit.x;
      for (int k = 0; k < dims; ++k) {
        // At most two nodes per step: the interpolant is only piecewise linear.
        const double s = std::isfinite(step[k]) ? std::clamp(step[k], -2.0, 2.0) : 0.0;
        candidate[k] = std::clamp(fit.x[k] + s, 0.0, nodes[k] - 1.0);
      }
      double moved = 0;
      for (int k = 0; k < dims; ++k) moved = std::max(moved, std::abs(candidate[k] - fit.x[k]));
      if (moved < 1e-4) return fit;  // converged (or stuck at a bound)
      const double chi2 = evaluate(candidate, true);
      if (chi2 < fit.chi2) {
        accepted = true;
        const double gain = fit.chi2 - chi2;
        fit.x = candidate;
        fit.chi2 = chi2;
        lambda = std::max(lambda / 4, 1e-7);
        if (moved < 2e-3 || gain < 1e-6 * (1 + chi2)) return fit;
      } else {
        lambda *= 8;
      }
    }
    if (!accepted) {
      interpolate(fit.x, predicted, jacobian);  // restore the Jacobian at the accepted point
      return fit;
    }
  }
  return fit;
}

namespace {

// χ² over one contiguous Ch row of nodes; C known at compile time so the
// channel loop unrolls and the row loop vectorises.
template <int C>
void scan_row(const float* row, int count, int stride, const float* m, const float* w, float& best, int& best_index) {
  if (stride != 1) {
    for (int i = 0; i < count; i += stride) {
      const float* node = row + static_cast<std::size_t>(i) * C;
      float chi2 = 0;
      for (int c = 0; c < C; ++c) {
        const float r = (node[c] - m[c]) * w[c];
        chi2 += r * r;
      }
      if (chi2 < best) best = chi2, best_index = i;
    }
    return;
  }
  // Contiguous nodes: χ² of a block without branches (vectorised), then its minimum.
  constexpr int kBlock = 64;
  float chi2[kBlock];
  for (int first = 0; first < count; first += kBlock) {
    const int n = std::min(kBlock, count - first);
    const float* block = row + static_cast<std::size_t>(first) * C;
    for (int i = 0; i < n; ++i) {
      float sum = 0;
      for (int c = 0; c < C; ++c) {
        const float r = (block[i * C + c] - m[c]) * w[c];
        sum += r * r;
      }
      chi2[i] = sum;
    }
    float block_best = best;
    int block_index = -1;
    for (int i = 0; i < n; ++i)
      if (chi2[i] < block_best) block_best = chi2[i], block_index = i;
    if (block_index >= 0) best = block_best, best_index = first + block_index;
  }
}

void scan_row_any(int channels, const float* row, int count, int stride, const float* m, const float* w, float& best,
                  int& best_index) {
  switch (channels) {
    case 3: return scan_row<3>(row, count, stride, m, w, best, best_index);
    case 4: return scan_row<4>(row, count, stride, m, w, best, best_index);
    case 6: return scan_row<6>(row, count, stride, m, w, best, best_index);
    default:
      for (int i = 0; i < count; i += stride) {
        const float* node = row + static_cast<std::size_t>(i) * channels;
        float chi2 = 0;
        for (int c = 0; c < channels; ++c) {
          const float r = (node[c] - m[c]) * w[c];
          chi2 += r * r;
        }
        if (chi2 < best) best = chi2, best_index = i;
      }
  }
}

}  // namespace

GridPoint Inverter::node_search(const double* measured, const double* weight, int order, int stride) const {
  const auto n = table_->nodes();
  const int channels = table_->channels();
  ChannelBuffer<float> m(channels), w(channels);
  for (int c = 0; c < channels; ++c) m[c] = static_cast<float>(measured[c]), w[c] = static_cast<float>(weight[c]);
  float best = std::numeric_limits<float>::infinity();
  GridPoint best_x{0, 0, bm_2d_coordinate(), 0};
  const int bm_2d = static_cast<int>(std::lround(bm_2d_coordinate()));
  const int outer_stride = order == 4 ? std::max(1, stride / 2) : 1;
  const int bm_first = order == 4 ? 0 : bm_2d, bm_last = order == 4 ? n[2] - 1 : bm_2d;
  const int che_last = order == 4 ? n[3] - 1 : 0;
  for (int i_bm = bm_first; i_bm <= bm_last; i_bm += outer_stride) {
    for (int i_che = 0; i_che <= che_last; i_che += outer_stride) {
      for (int i_cm = 0; i_cm < n[0]; i_cm += stride) {
        int best_ch = -1;
        scan_row_any(channels, table_->node(i_cm, 0, i_bm, i_che), n[1], stride, m, w, best, best_ch);
        if (best_ch >= 0) best_x = {double(i_cm), double(best_ch), double(i_bm), double(i_che)};
      }
    }
  }
  return best_x;
}

GridPoint Inverter::node_descent(const double* measured, const double* weight, int order, GridPoint start,
                                 bool diagonal_moves) const {
  const auto n = table_->nodes();
  const int channels = table_->channels();
  int at[4] = {static_cast<int>(std::lround(start[0])), static_cast<int>(std::lround(start[1])),
               static_cast<int>(std::lround(start[2])), static_cast<int>(std::lround(start[3]))};
  if (order != 4) at[2] = static_cast<int>(std::lround(bm_2d_coordinate())), at[3] = 0;
  auto chi2_of = [&](const int* i) {
    const float* node = table_->node(i[0], i[1], i[2], i[3]);
    double chi2 = 0;
    for (int c = 0; c < channels; ++c) {
      const double r = (node[c] - measured[c]) * weight[c];
      chi2 += r * r;
    }
    return chi2;
  };
  double best = chi2_of(at);
  const int dims = order == 4 ? 4 : 2;
  // Axis-wise moves (2·dims neighbours), then the diagonal ones only when no
  // axis move helps: most steps cost 8 node evaluations instead of 80.
  const int full = dims == 4 ? 81 : 9;
  for (int step = 0; step < 96; ++step) {
    int best_move[4] = {at[0], at[1], at[2], at[3]};
    for (int d = 0; d < dims; ++d)
      for (int delta : {-1, 1}) {
        int candidate[4] = {at[0], at[1], at[2], at[3]};
        candidate[d] += delta;
        if (candidate[d] < 0 || candidate[d] >= n[d]) continue;
        const double chi2 = chi2_of(candidate);
        if (chi2 < best) best = chi2, std::copy(candidate, candidate + 4, best_move);
      }
    if (std::equal(best_move, best_move + 4, at)) {
      if (!diagonal_moves) break;
      for (int k = 0; k < full; ++k) {
        int candidate[4] = {at[0], at[1], at[2], at[3]};
        int code = k;
        bool inside = true;
        for (int d = 0; d < dims; ++d, code /= 3) {
          candidate[d] += code % 3 - 1;
          inside = inside && candidate[d] >= 0 && candidate[d] < n[d];
        }
        if (!inside) continue;
        const double chi2 = chi2_of(candidate);
        if (chi2 < best) best = chi2, std::copy(candidate, candidate + 4, best_move);
      }
      if (std::equal(best_move, best_move + 4, at)) break;
    }
    std::copy(best_move, best_move + 4, at);
  }
  return {double(at[0]), double(at[1]), double(at[2]), double(at[3])};
}

Fit ExhaustiveInverter::fit(const double* measured, const double* weight, int order) const {
  return refine(measured, weight, order, node_search(measured, weight, order, 1), 30);
}

Fit TwoDInverter::fit(const double* measured, const double* weight, int) const {
  return refine(measured, weight, 2, node_search(measured, weight, 2, 1), 30);
}

GridPoint Inverter::node_point(std::uint32_t node) const {
  const auto n = table_->nodes();
  const std::uint32_t i_ch = node % n[1], i_cm = node / n[1] % n[0], i_che = node / (n[1] * n[0]) % n[3],
                      i_bm = node / (n[1] * n[0] * n[3]);
  return {double(i_cm), double(i_ch), double(i_bm), double(i_che)};
}

Fit Inverter::search_bucket(const InverseTable& inverse, const float* bucket_values, const double* measured,
                            const double* weight, int order, const std::function<GridPoint()>& outside_start) const {
  const int channels = table_->channels();
  ChannelBuffer<float> m(channels), w(channels);
  for (int c = 0; c < channels; ++c) m[c] = static_cast<float>(measured[c]), w[c] = static_cast<float>(weight[c]);
  const std::uint32_t cell_index = inverse.cell_of(m);
  const bool in_table = cell_index != InverseTable::kNoCell;
  GridPoint start;
  if (in_table) {
    const InverseTable::Cell& cell = inverse.cell(cell_index);
    const std::uint32_t* nodes = inverse.bucket_nodes().data() + cell.bucket_begin;
    float best = std::numeric_limits<float>::infinity();
    int best_index = 0;
    if (bucket_values) {
      scan_nodes(channels, bucket_values + std::size_t(cell.bucket_begin) * channels, static_cast<int>(cell.bucket_count),
                 m, w, best, best_index);
    } else {
      for (std::uint32_t i = 0; i < cell.bucket_count; ++i) {
        int found = -1;
        scan_nodes(channels, table_->values().data() + std::size_t(nodes[i]) * channels, 1, m, w, best, found);
        if (found >= 0) best_index = static_cast<int>(i);
      }
    }
    start = node_point(nodes[best_index]);
  } else {
    start = outside_start();
  }
  return refine(measured, weight, order, node_descent(measured, weight, order, start, !in_table), 20);
}

void Inverter::scan_nodes(int channels, const float* values, int count, const float* measured, const float* weight,
                          float& best, int& best_index) {
  scan_row_any(channels, values, count, 1, measured, weight, best, best_index);
}

}  // namespace chromo::estimation
