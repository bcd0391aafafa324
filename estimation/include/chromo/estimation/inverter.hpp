#pragma once
// Inverters: measurement vector → skin parameters, all behind one interface.
//
// An inverter fits one pixel at a time for a given model order (4: Cm, Ch, βm,
// Che free; 2: Cm, Ch free with βm = 0.7, Che = 0) and returns the parameters
// with the weighted residual χ² = Σ_c ((predicted_c − measured_c)·weight_c)²,
// weight_c = 1/σ_c from the camera noise model. It does not flag or select a
// model order: Estimator (estimator.hpp) does that on top of any inverter.
//
// All three predict through the same interpolated ForwardTable, so they differ
// only in how they search:
//  - ExhaustiveInverter: the reference. Evaluates χ² at every node of the
//    table (4D) or of the 2D slice, then polishes the best node with bounded
//    Levenberg-Marquardt on the interpolated table (as the paper's "4D search"
//    plus a sub-node refinement, so its accuracy is not limited by node spacing).
//  - FastInverter: a pre-solved inverse table in measurement space
//    (inverse_table.hpp, cached on disk next to the forward table). For a
//    4-channel set in 4D a pixel costs one cell lookup; per branch of the
//    non-unique inverse stored for its cell (an empty cell: its neighbour's
//    and its own pre-solved bounded fit, see Options::empty_cell_branch_first),
//    a linear step x0 + J⁺·(m − m0) and one float interpolation (value only) for its χ² (and the branch's
//    own x0 when the step overshoots); then up to Options::chord_steps chord
//    steps x += J⁺·(m − f(x)) with the best branch's stored J⁺ while each
//    halves χ² (no Jacobian, no solve); then, unless χ² ≤
//    Options::converged_chi2 already, bounded Gauss-Newton on the
//    interpolated table (Newton where no bound is active) until χ² ≤
//    converged_chi2 or the step stalls (on a bound face with an acceptable
//    χ²: gains below Options::face_stall_relative), at most
//    Options::newton_steps. A
//    converged fit with χ² ≤ Options::presolved_accept_chi2 is the answer
//    (≈ 99.8% of noise-free and ≈ 99.6-99.7% of noisy in-gamut skin pixels).
//    Otherwise (far outside the gamut, several bounded local minima, no
//    convergence) the search path too, and the smaller χ² wins: the best χ²
//    node of the cell's node bucket (every branch reaching the cell
//    competes), descent over neighbouring nodes, ≤ 20 bounded LM steps
//    (refine()); outside the table a coarse node search seeds it. Order 2
//    alike from the cell's pre-solved 2D fit (Options::presolved_slice; its
//    search path starts from the 4D seed projected onto the 2D slice). Sets
//    of other than four channels use the search path only.
//  - TwoDInverter: ExhaustiveInverter restricted to the 2D slice for every
//    order (the 2D model of Jimenez et al. as the seed uses it).
//
// Thread rules: inverters are immutable after construction; fit() may be
// called concurrently from any number of threads. They hold a shared_ptr to
// the table.

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "chromo/estimation/channel_buffer.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/inverse_table.hpp"

namespace chromo::estimation {

struct Fit {
  GridPoint x{};       // grid coordinates of the fitted parameters
  double chi2 = 0;     // weighted residual
  int iterations = 0;  // LM iterations used
  // The table's prediction at x when the inverter has it at hand (callers
  // need not interpolate again): only the fast inverter's four-channel path
  // sets it (kPredictedChannels values); any other fit leaves it false.
  static constexpr int kPredictedChannels = 4;
  bool has_prediction = false;
  double predicted[kPredictedChannels] = {};
};

class Inverter {
 public:
  explicit Inverter(std::shared_ptr<const ForwardTable> table) : table_(std::move(table)) {}
  virtual ~Inverter() = default;
  virtual std::string_view name() const = 0;
  // measured, weight: table().channels() values each. order: 2 or 4.
  virtual Fit fit(const double* measured, const double* weight, int order) const = 0;
  const ForwardTable& table() const { return *table_; }

  // Grid coordinates of the 2D model's fixed βm = 0.7, Che = 0.
  double bm_2d_coordinate() const { return 0.7 * (table_->grid().bm_nodes - 1); }

  // Bounded LM on the interpolated table from `start` (order 2 holds x[2], x[3]
  // at the 2D model's values). Public so that other searches can reuse it.
  Fit refine(const double* measured, const double* weight, int order, GridPoint start, int max_iterations) const;
  double chi2_at(const double* measured, const double* weight, const GridPoint& x) const;

 protected:
  // Best node by χ²: over the whole table (order 4) or the 2D slice (order 2),
  // visiting every `stride`-th node along Cm and Ch (and βm, Che for order 4).
  GridPoint node_search(const double* measured, const double* weight, int order, int stride) const;

  // Discrete descent on the nodes: from `start` (rounded), move to the best of
  // the 2·order axis neighbours, and when none is better (only if
  // diagonal_moves) of all 3^order − 1 neighbouring nodes, until none is better.
  // A seed already best in its measurement cell needs no diagonal moves (they
  // cost 80 node evaluations and changed no result in the bench).
  GridPoint node_descent(const double* measured, const double* weight, int order, GridPoint start,
                         bool diagonal_moves = true) const;

  // The search path of the fast and the subspace inverters: the best node by
  // the weighted χ² among the nodes of the pixel's inverse-table bucket (the
  // nodes of every branch of the non-unique inverse there; bucket_values: the
  // bucket nodes' table values in inverse.bucket_nodes() order, or null to
  // read them from the table), or outside the inverse table outside_start();
  // then node_descent (diagonal moves outside only) and refine (20 steps).
  Fit search_bucket(const InverseTable& inverse, const float* bucket_values, const double* measured,
                    const double* weight, int order, const std::function<GridPoint()>& outside_start) const;
  // Grid coordinates of a node of the table, by its index (ForwardTable layout).
  GridPoint node_point(std::uint32_t node) const;

  // The table's value (and Jacobian, when not null) at x for refine():
  // ForwardTable::predict here; FastInverter's float interpolation for
  // 4-channel tables.
  virtual void interpolate(const GridPoint& x, double* value, double* jacobian) const;

  // χ² of `count` contiguous nodes' values; updates best/best_index (index in 0..count-1).
  static void scan_nodes(int channels, const float* values, int count, const float* measured, const float* weight,
                         float& best, int& best_index);

  std::shared_ptr<const ForwardTable> table_;
};

class ExhaustiveInverter : public Inverter {
 public:
  using Inverter::Inverter;
  std::string_view name() const override { return "exhaustive"; }
  Fit fit(const double* measured, const double* weight, int order) const override;
};

class TwoDInverter : public Inverter {
 public:
  using Inverter::Inverter;
  std::string_view name() const override { return "2d"; }
  Fit fit(const double* measured, const double* weight, int order) const override;
};

// How FastInverter's fit of a pixel ended (counted by fit_path_counts()).
enum class FastPath { kPresolved, kSearched, kCount };

// FastInverter's stopping and acceptance settings (χ² in the units of fit():
// noise-weighted, so 1 is one σ of camera noise in one channel).
struct FastInverterOptions {
  int newton_steps = 16;              // at most this many Gauss-Newton iterations after the linear step
  double converged_chi2 = 0.01;       // stop (and skip Gauss-Newton) at or below this χ²
  int chord_steps = 3;                // linear steps with the cell's stored J⁺ before Gauss-Newton
  // A converged pre-solved fit at or below this χ² is the answer; above it
  // the search path runs too (another fold's lower minimum) and the smaller
  // χ² wins (fit()). 10.83 ≈ the χ²₁ 0.999 quantile, the Estimator's 4D flag
  // threshold for four channels at its default significance, and the
  // Estimator caps it at its own flag threshold: the search runs only where
  // the pre-solved fit would be flagged. (It was 4: the virtual lab's noisy
  // skin ×1.15-1.22 faster, relit ΔE94 1.627 → 1.660 against the truth, D65
  // +0.042 → +0.049 from the exhaustive search; docs/estimation.md.)
  double presolved_accept_chi2 = 10.83;
  // Gauss-Newton with a coordinate held at its bound and χ² ≤
  // presolved_accept_chi2 stops when a step lowers χ² by less than this
  // share of it (elsewhere 10⁻⁴): noisy pixels off the gamut's thin sheet
  // crawl along a bound face in small steps that do not change their colour.
  double face_stall_relative = 0.05;
  // false: the pre-solved path's best point is the answer whatever its χ²
  // and convergence (the search path then runs only where the pixel's key
  // cell holds no branch to start from). With few newton_steps this trades accuracy
  // and flags for speed; bench/fast_budget_bench charts the trade.
  bool search_fallback = true;
  // An empty inverse-table cell's own pre-solved branch (InverseTable)
  // competes with its neighbour's branches from the start (true: a noisy
  // pixel starts on its own bound face; the virtual lab's noisy skin ×1.5
  // faster, relit ΔE94 1.54 → 1.63 against the truth, docs/estimation.md),
  // or is tried only where they end above presolved_accept_chi2, before the
  // search path (false: ×1.1-1.2, relit 1.56).
  bool empty_cell_branch_first = true;
  // The 2D fit (order 2; the auto model's second fit) starts from the inverse
  // table's pre-solved 2D fit at the pixel's cell, as the 4D fit starts from
  // its branches (a linear step, chord steps, Gauss-Newton along the slice),
  // and takes the search path only where that fit does not converge. A
  // converged 2D fit above presolved_accept_chi2 is a pixel the 2D model does
  // not explain: the search found a lower 2D minimum on half of such
  // synthetic pixels, for 4.3 µs each, and changed no order decision on
  // 40,000 of them. false: the search path always (the 4D bucket's best node
  // projected onto the slice, a node walk along it, LM).
  bool presolved_slice = true;
  // How the inverse table is built (part of its cache key): whether its
  // empty cells hold pre-solved branches, and the channels' relative noise
  // those fits weigh with (Estimator: from its measurement set when all zero).
  InverseTableSettings inverse_table;
  bool IsValid(std::string* error) const;
};

class FastInverter : public Inverter {
 public:
  using Options = FastInverterOptions;
  // Loads or builds the inverse table in cache_dir (empty: ForwardTable::default_cache_dir()).
  // Throws std::invalid_argument for invalid options.
  explicit FastInverter(std::shared_ptr<const ForwardTable> table, const std::filesystem::path& cache_dir = {},
                        Options options = {});
  FastInverter(std::shared_ptr<const ForwardTable> table, std::shared_ptr<const InverseTable> inverse,
               Options options = {});
  const Options& options() const { return options_; }
  std::string_view name() const override { return "fast"; }
  Fit fit(const double* measured, const double* weight, int order) const override;
  // As fit(), and says which path ended it.
  Fit fit(const double* measured, const double* weight, int order, FastPath* path) const;
  const InverseTable& inverse_table() const { return *inverse_; }
  // Share of inverse-table cells holding a seed (for reports).
  double filled_share() const;
  // The table's interpolation for 4-channel tables in float, AVX-friendly
  // (x: grid coordinates; value: 4; jacobian: 16 row-major, or null). Public
  // for the bench's cost breakdown.
  void predict4(const float* x, float* value, float* jacobian) const;
  // The two paths fit() combines (public for the bench's cost breakdown):
  // the pre-solved path (4 channels, order 4; false when it did not
  // converge, `fit` then holds the best point reached) and the search path.
  bool fit_presolved(const double* measured, const double* weight, Fit& fit) const;
  // The pre-solved path of the 2D fit (Options::presolved_slice), alike.
  bool fit_presolved_slice(const double* measured, const double* weight, Fit& fit) const;
  Fit fit_by_search(const double* measured, const double* weight, int order) const;
  // Whether `measured` falls in an inverse-table cell that holds table nodes
  // itself (false: an empty cell pointing at a neighbour, or outside).
  bool in_occupied_cell(const double* measured) const;

 private:
  Options options_;
  std::shared_ptr<const InverseTable> inverse_;
  std::vector<float> bucket_values_;  // table values of inverse_->bucket_nodes(), same order
  // The seed of measurements outside the inverse table (tattoo ink, marker,
  // the Estimator's specular refits), in two levels. Level 1: every
  // kCoarseStride-th node along Cm and Ch and every (kCoarseStride/2)-th
  // along βm and Che, contiguous (one vectorised scan). Level 2: the nodes at
  // half those spacings around the kCoarseCandidates best level-1 nodes (the
  // 3⁴ − 1 half-way neighbours of each). 1,296 + 324 node χ² instead of the
  // 14,641 of one level at half the spacing, which took 69% of a tattoo
  // pixel's fit (docs/estimation.md, "Inverters" and "The whole frame").
  static constexpr int kCoarseStride = 8;
  static constexpr int kCoarseCandidates = 4;
  std::vector<float> coarse_values_;  // channel-major: channel c of node i at [c * coarse_nodes_.size() + i]
  std::vector<std::array<int, 4>> coarse_nodes_;
  GridPoint coarse_search(const double* measured, const double* weight) const;
  std::size_t step_[4] = {};          // floats between neighbouring nodes along each axis
  bool presolved_ = false;            // 4 channels: the linear-step path is available
  void init();
  std::array<float, 4> upper_bounds() const;  // largest grid coordinate per axis
  // The inverse-table cell of a 4-channel measurement (m: its 4 values as
  // floats, filled in), or null.
  const InverseTable::Cell* presolved_cell(const double* measured, float* m) const;
  void interpolate(const GridPoint& x, double* value, double* jacobian) const override;
};

}  // namespace chromo::estimation
