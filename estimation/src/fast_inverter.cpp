// FastInverter (inverter.hpp): the pre-solved inverse table path, and the
// node-bucket search it falls back to.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "chromo/estimation/inverse_table.hpp"
#include "chromo/estimation/inverter.hpp"
#include "spd_solve.hpp"
#include "cell_position.hpp"

namespace chromo::estimation {

bool FastInverterOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (newton_steps < 0 || newton_steps > 1000) return fail("newton_steps must be in 0..1000");
  if (chord_steps < 0 || chord_steps > 1000) return fail("chord_steps must be in 0..1000");
  if (!(face_stall_relative >= 0 && face_stall_relative < 1)) return fail("face_stall_relative must be in [0, 1)");
  if (!(converged_chi2 >= 0)) return fail("converged_chi2 must be >= 0");
  if (!(presolved_accept_chi2 >= converged_chi2)) return fail("presolved_accept_chi2 must be >= converged_chi2");
  std::string table_error;
  if (!inverse_table.IsValid(&table_error)) {
    if (error) *error = "inverse_table: " + table_error;
    return false;
  }
  return true;
}

FastInverter::FastInverter(std::shared_ptr<const ForwardTable> table, const std::filesystem::path& cache_dir,
                           Options options)
    : Inverter(table), options_(options) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("fast inverter options: " + error);
  inverse_ = InverseTable::load_or_build(table_, cache_dir.empty() ? ForwardTable::default_cache_dir() : cache_dir,
                                         nullptr, nullptr, 0, options_.inverse_table);
  init();
}

FastInverter::FastInverter(std::shared_ptr<const ForwardTable> table, std::shared_ptr<const InverseTable> inverse,
                           Options options)
    : Inverter(std::move(table)), options_(options), inverse_(std::move(inverse)) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("fast inverter options: " + error);
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
  // The level-1 nodes of coarse_search().
  const auto n = t.nodes();
  const int outer = std::max(1, kCoarseStride / 2);
  for (int i_bm = 0; i_bm < n[2]; i_bm += outer)
    for (int i_che = 0; i_che < n[3]; i_che += outer)
      for (int i_cm = 0; i_cm < n[0]; i_cm += kCoarseStride)
        for (int i_ch = 0; i_ch < n[1]; i_ch += kCoarseStride) coarse_nodes_.push_back({i_cm, i_ch, i_bm, i_che});
  // Channel-major (all nodes' channel 0, then channel 1, ...): the level-1
  // scan runs across nodes, eight per AVX instruction.
  const std::size_t count = coarse_nodes_.size();
  coarse_values_.resize(count * channels);
  for (std::size_t i = 0; i < count; ++i) {
    const auto& at = coarse_nodes_[i];
    const float* v = t.node(at[0], at[1], at[2], at[3]);
    for (int c = 0; c < channels; ++c) coarse_values_[c * count + i] = v[c];
  }
}

GridPoint FastInverter::coarse_search(const double* measured, const double* weight) const {
  const int channels = table_->channels();
  ChannelBuffer<float> m(channels), w(channels);
  for (int c = 0; c < channels; ++c) m[c] = static_cast<float>(measured[c]), w[c] = static_cast<float>(weight[c]);
  // Level 1: the kCoarseCandidates smallest χ² (NaN never enters), computed
  // a block of nodes at a time, one channel after the other (the same sum
  // per node as scan_nodes, in the same order).
  const int count = static_cast<int>(coarse_nodes_.size());
  std::array<float, kCoarseCandidates> best_chi2;
  std::array<int, kCoarseCandidates> best_index;
  best_chi2.fill(std::numeric_limits<float>::infinity());
  best_index.fill(-1);
  constexpr int kBlock = 256;
  float block_chi2[kBlock];
  for (int first = 0; first < count; first += kBlock) {
    const int size = std::min(kBlock, count - first);
    std::fill_n(block_chi2, size, 0.0f);
    for (int c = 0; c < channels; ++c) {
      const float* v = coarse_values_.data() + std::size_t(c) * count + first;
      const float mc = m[c], wc = w[c];
      for (int i = 0; i < size; ++i) {
        const float r = (v[i] - mc) * wc;
        block_chi2[i] += r * r;
      }
    }
    for (int i = 0; i < size; ++i) {
      const float chi2 = block_chi2[i];
      if (!(chi2 < best_chi2.back())) continue;
      int k = kCoarseCandidates - 1;
      for (; k > 0 && chi2 < best_chi2[k - 1]; --k) best_chi2[k] = best_chi2[k - 1], best_index[k] = best_index[k - 1];
      best_chi2[k] = chi2, best_index[k] = first + i;
    }
  }
  if (best_index[0] < 0) return {0, 0, bm_2d_coordinate(), 0};  // as node_search: no finite χ²
  // Level 2: the half-way nodes around each candidate.
  const auto n = table_->nodes();
  const int half[4] = {kCoarseStride / 2, kCoarseStride / 2, std::max(1, kCoarseStride / 4),
                       std::max(1, kCoarseStride / 4)};
  float best = best_chi2[0];
  std::array<int, 4> at = coarse_nodes_[best_index[0]];
  for (int k = 0; k < kCoarseCandidates && best_index[k] >= 0; ++k) {
    const std::array<int, 4>& centre = coarse_nodes_[best_index[k]];
    for (int code = 0; code < 81; ++code) {
      if (code == 40) continue;  // the candidate itself: already scanned
      std::array<int, 4> node;
      bool inside = true;
      for (int d = 0, rest = code; d < 4; ++d, rest /= 3) {
        node[d] = centre[d] + (rest % 3 - 1) * half[d];
        inside = inside && node[d] >= 0 && node[d] < n[d];
      }
      if (!inside) continue;
      int found = -1;
      scan_nodes(channels, table_->node(node[0], node[1], node[2], node[3]), 1, m, w, best, found);
      if (found >= 0) at = node;
    }
  }
  return {double(at[0]), double(at[1]), double(at[2]), double(at[3])};
}

bool FastInverter::in_occupied_cell(const double* measured) const {
  const int channels = table_->channels();
  ChannelBuffer<float> m(channels);
  for (int c = 0; c < channels; ++c) m[c] = static_cast<float>(measured[c]);
  const std::uint32_t box = inverse_->box_of(m), cell_index = inverse_->cell_at(box);
  if (cell_index == InverseTable::kNoCell) return false;
  // An occupied cell's bucket holds the nodes whose own values fall in it.
  const std::uint32_t node = inverse_->bucket_nodes()[inverse_->cell(cell_index).bucket_begin];
  return inverse_->box_of(table_->values().data() + std::size_t(node) * channels) == box;
}

double FastInverter::filled_share() const { return inverse_->filled_share(); }

namespace {
using Float8 = float __attribute__((vector_size(32)));
}  // namespace

// The 16 corners of the cell around x: along Ch the two corners are adjacent
// in memory (8 floats), so 8 loads of 8 floats cover the cell. S sums the
// corner values weighted along Cm, βm, Che (not Ch); the value interpolates
// S's two halves along Ch, the Ch derivative is their difference, and the
// other derivatives sum Ch-weighted values with one axis' factor replaced by ∓1.
void FastInverter::predict4(const float* x, float* value, float* jacobian) const {
  const detail::CellPosition cell = detail::cell_position(x, table_->nodes());
  const int* base = cell.base;
  const float* f = cell.fraction;
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

namespace {

// A point of the 4-channel Gauss-Newton with its prediction and Jacobian (the next step needs both).
struct Point {
  float x[4], predicted[4], jacobian[16];
  double chi2 = std::numeric_limits<double>::infinity();
  bool has_jacobian = false;
};

// χ² of p.x (prediction, and the Jacobian when asked for, filled in).
void evaluate(const FastInverter& inverter, const double* measured, const double* weight, Point& p,
              bool with_jacobian = true) {
  inverter.predict4(p.x, p.predicted, with_jacobian ? p.jacobian : nullptr);
  p.has_jacobian = with_jacobian;
  p.chi2 = 0;
  for (int c = 0; c < 4; ++c) {
    const double r = (p.predicted[c] - measured[c]) * weight[c];
    p.chi2 += r * r;
  }
}

// Bounded Gauss-Newton on the interpolated table from `best` (evaluated)
// (Newton where no bound is active: four channels, four parameters), with
// backtracking: the interpolant is only piecewise multilinear. True when it
// converged (χ² ≤ converged_chi2, a stalled step or a bounded minimum).
bool gauss_newton(const FastInverter& inverter, const double* measured, const double* weight, const float* upper,
                  int free_dims, Point& best, int& iterations) {
  const FastInverterOptions& options = inverter.options();
  bool converged = best.chi2 <= options.converged_chi2;
  if (!converged && !best.has_jacobian) evaluate(inverter, measured, weight, best);
  // Stalled: a gain below 10⁻⁴ of χ², or in 4D with a coordinate held on a
  // bound face and χ² already acceptable, below face_stall_relative of it.
  // (Not in 2D: the last few per cent of χ²₂ there decide the model order.)
  auto stall_share = [&](bool held, double chi2) {
    return held && free_dims == 4 && chi2 <= options.presolved_accept_chi2
               ? std::max(options.face_stall_relative, 1e-4)
               : 1e-4;
  };
  Point trial;
  for (iterations = 0; iterations < options.newton_steps && !converged; ++iterations) {
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
    // A coordinate at its bound whose gradient points outward is held (and
    // the 2D model's βm and Che always).
    bool held = false;
    double step[4];
    // Stalled already by the Gauss-Newton model: its predicted gain
    // (gradient·step, χ² − |r − J·step|²) below the stall share of χ².
    // A noisy pixel that starts on its own face (a pre-solved empty cell)
    // then ends without a trial evaluation.
    const double predicted_gain =
        detail::bounded_gauss_newton_step(jtj, gradient, best.x, upper, free_dims, step, &held);
    if (predicted_gain < stall_share(held, best.chi2) * best.chi2) {
      converged = true;
      break;
    }
    bool improved = false;
    for (float scale = 1.0f; scale > 0.005f && !improved; scale *= 0.5f) {
      float moved = 0;
      for (int k = 0; k < 4; ++k) {
        trial.x[k] = std::clamp(best.x[k] - std::clamp(scale * static_cast<float>(step[k]), -4.0f, 4.0f), 0.0f, upper[k]);
        moved = std::max(moved, std::abs(trial.x[k] - best.x[k]));
      }
      evaluate(inverter, measured, weight, trial);
      if (trial.chi2 < best.chi2) {
        // (The face stall: noisy pixels off the gamut's sheet crawl along a
        // bound face; never where the search path would follow.)
        converged = trial.chi2 <= options.converged_chi2 || moved < 1e-3f ||
                    best.chi2 - trial.chi2 < stall_share(held, trial.chi2) * best.chi2;
        best = trial, improved = true;
      }
    }
    if (!improved) converged = true;  // no descent along the GN direction: a (bounded) minimum
  }
  return converged;
}

void store(const Point& p, int iterations, Fit& fit) {
  fit.x = {p.x[0], p.x[1], p.x[2], p.x[3]};
  fit.chi2 = p.chi2;
  fit.iterations = iterations;
  fit.has_prediction = true;
  std::copy_n(p.predicted, 4, fit.predicted);
}

}  // namespace

std::array<float, 4> FastInverter::upper_bounds() const {
  const auto n = table_->nodes();
  return {float(n[0] - 1), float(n[1] - 1), float(n[2] - 1), float(n[3] - 1)};
}

// The search path's LM (refine()) through the float interpolation: the
// generic double-precision one cost ≈ 10× as much per call.
void FastInverter::interpolate(const GridPoint& x, double* value, double* jacobian) const {
  if (!presolved_) return Inverter::interpolate(x, value, jacobian);
  const float xf[4] = {float(x[0]), float(x[1]), float(x[2]), float(x[3])};
  float v[4], j[16];
  predict4(xf, v, jacobian ? j : nullptr);
  std::copy_n(v, 4, value);
  if (jacobian) std::copy_n(j, 16, jacobian);
}

namespace {

// From the best linear step of `branches` (each branch's own x0 too where its
// step overshoots): chord steps with that branch's J⁺, then Gauss-Newton.
// True when converged; `best` holds the end point.
bool descend(const FastInverter& inverter, const float* m, const double* measured, const double* weight,
             const InverseTable::Branch* const* branches, int count, const float* upper, int free_dims, Point& best,
             int& iterations) {
  const FastInverterOptions& options = inverter.options();
  Point trial;
  const InverseTable::Branch* best_branch = nullptr;
  for (int b = 0; b < count && best.chi2 > options.converged_chi2; ++b) {
    const InverseTable::Branch& branch = *branches[b];
    for (int k = 0; k < 4; ++k) {
      float step = 0;
      for (int c = 0; c < 4; ++c) step += branch.jinv[k * 4 + c] * (m[c] - branch.m0[c]);
      trial.x[k] = std::clamp(branch.x0[k] + step, 0.0f, upper[k]);
    }
    evaluate(inverter, measured, weight, trial, false);
    if (trial.chi2 < best.chi2) best = trial, best_branch = &branch;
    if (trial.chi2 > options.presolved_accept_chi2) {
      std::copy_n(branch.x0, 4, trial.x);
      evaluate(inverter, measured, weight, trial, false);
      if (trial.chi2 < best.chi2) best = trial, best_branch = &branch;
    }
  }
  iterations = 0;
  if (!std::isfinite(best.chi2)) return false;
  // Chord steps: the branch's stored J⁺ again from the current point (no
  // Jacobian, no solve), while each halves χ² at least; Gauss-Newton then
  // takes over where they stall (a bound, a dropped direction, curvature).
  for (int s = 0; s < options.chord_steps && best_branch->has_step() && best.chi2 > options.converged_chi2; ++s) {
    float r[4];
    for (int c = 0; c < 4; ++c) r[c] = m[c] - best.predicted[c];
    for (int k = 0; k < 4; ++k) {
      float step = 0;
      for (int c = 0; c < 4; ++c) step += best_branch->jinv[k * 4 + c] * r[c];
      trial.x[k] = std::clamp(best.x[k] + step, 0.0f, upper[k]);
    }
    evaluate(inverter, measured, weight, trial, false);
    if (!(trial.chi2 < 0.5 * best.chi2)) {
      if (trial.chi2 < best.chi2) best = trial;
      break;
    }
    best = trial;
  }
  return gauss_newton(inverter, measured, weight, upper, free_dims, best, iterations);
}

}  // namespace

const InverseTable::Cell* FastInverter::presolved_cell(const double* measured, float* m) const {
  for (int c = 0; c < 4; ++c) m[c] = static_cast<float>(measured[c]);
  const std::uint32_t cell_index = inverse_->cell_of(m);
  return cell_index == InverseTable::kNoCell ? nullptr : &inverse_->cell(cell_index);
}

bool FastInverter::fit_presolved(const double* measured, const double* weight, Fit& fit) const {
  float m[4];
  const InverseTable::Cell* found = presolved_cell(measured, m);
  if (!found) return false;
  const InverseTable::Cell& cell = *found;
  const std::array<float, 4> upper = upper_bounds();
  const InverseTable::Branch* list[InverseTable::kMaxBranches + 1];
  int count = 0;
  for (std::uint32_t b = 0; b < cell.branch_count; ++b) list[count++] = inverse_->branches(cell) + b;
  const InverseTable::Branch* own =
      cell.presolved_branch != InverseTable::kNoCell ? &inverse_->branch(cell.presolved_branch) : nullptr;
  // An empty cell's own pre-solved branch competes with its neighbour's from
  // the start, or only where they end above the acceptance χ² (options).
  const bool own_later = own && !options_.empty_cell_branch_first;
  if (own && !own_later) list[count++] = own;
  Point best;
  int iterations = 0;
  bool converged = descend(*this, m, measured, weight, list, count, upper.data(), 4, best, iterations);
  if (own_later && !(converged && best.chi2 <= options_.presolved_accept_chi2)) {
    Point other;
    int more = 0;
    const bool other_converged = descend(*this, m, measured, weight, &own, 1, upper.data(), 4, other, more);
    iterations += more;
    if (other.chi2 < best.chi2 || !std::isfinite(best.chi2)) best = other, converged = other_converged;
  }
  if (!std::isfinite(best.chi2)) return false;
  store(best, iterations, fit);
  return converged;
}

bool FastInverter::fit_presolved_slice(const double* measured, const double* weight, Fit& fit) const {
  float m[4];
  const InverseTable::Cell* cell = presolved_cell(measured, m);
  if (!cell || cell->slice_branch == InverseTable::kNoCell) return false;
  const InverseTable::Branch* slice = &inverse_->branch(cell->slice_branch);
  const std::array<float, 4> upper = upper_bounds();
  Point best;
  int iterations = 0;
  const bool converged = descend(*this, m, measured, weight, &slice, 1, upper.data(), 2, best, iterations);
  if (!std::isfinite(best.chi2)) return false;
  store(best, iterations, fit);
  return converged;
}

Fit FastInverter::fit(const double* measured, const double* weight, int order) const {
  return fit(measured, weight, order, nullptr);
}

Fit FastInverter::fit(const double* measured, const double* weight, int order, FastPath* path) const {
  Fit presolved;
  presolved.chi2 = std::numeric_limits<double>::infinity();
  if (presolved_ && (order == 4 || options_.presolved_slice)) {
    const bool converged =
        order == 4 ? fit_presolved(measured, weight, presolved) : fit_presolved_slice(measured, weight, presolved);
    // A converged 2D fit is the answer whatever its χ² (Options::presolved_slice).
    const bool accepted = converged && (order == 2 || presolved.chi2 <= options_.presolved_accept_chi2);
    if (accepted || (!options_.search_fallback && std::isfinite(presolved.chi2))) {
      if (path) *path = FastPath::kPresolved;
      return presolved;
    }
  }
  if (path) *path = FastPath::kSearched;
  const Fit searched = fit_by_search(measured, weight, order);
  return searched.chi2 <= presolved.chi2 ? searched : presolved;
}

Fit FastInverter::fit_by_search(const double* measured, const double* weight, int order) const {
  // Outside the inverse table: the two-level node scan.
  return search_bucket(*inverse_, bucket_values_.data(), measured, weight, order,
                       [&] { return coarse_search(measured, weight); });
}

}  // namespace chromo::estimation
