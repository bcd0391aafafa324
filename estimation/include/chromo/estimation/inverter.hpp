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
//  - FastInverter: an inverse table in measurement space: the log of up to
//    four channels, kBins bins each, every table node bucketed into the cell
//    its predicted values fall in (nodes of one cell stored contiguously). A
//    pixel scans the nodes of its cell for the best χ² (every branch of the
//    non-unique inverse that reaches the cell competes, so the seed is the
//    exhaustive search's answer restricted to the cell), descends over
//    neighbouring nodes along the axes (the best node may lie in the next cell), then runs a
//    few bounded LM steps. Cells just outside the gamut share a neighbour's
//    bucket; a pixel outside those falls back to a coarse node search. Order
//    2 starts from the 4D seed projected onto the 2D slice. Construction
//    takes ~0.3 s and ~57 MB for the default table (42 MB of it the
//    cell index; not cached on disk).
//  - TwoDInverter: ExhaustiveInverter restricted to the 2D slice for every
//    order (the 2D model of Jimenez et al. as the seed uses it).
//
// Thread rules: inverters are immutable after construction; fit() may be
// called concurrently from any number of threads. They hold a shared_ptr to
// the table.

#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "chromo/estimation/forward_table.hpp"

namespace chromo::estimation {

struct Fit {
  GridPoint x{};       // grid coordinates of the fitted parameters
  double chi2 = 0;     // weighted residual
  int iterations = 0;  // LM iterations used
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

class FastInverter : public Inverter {
 public:
  static constexpr int kBins = 48;
  explicit FastInverter(std::shared_ptr<const ForwardTable> table);
  std::string_view name() const override { return "fast"; }
  Fit fit(const double* measured, const double* weight, int order) const override;
  // Share of inverse-table cells holding a seed (for reports).
  double filled_share() const;

 private:
  int key_dims_ = 0;
  double key_min_[4] = {}, key_scale_[4] = {};
  struct Bucket {
    std::uint32_t begin = 0, count = 0;  // range in bucket_nodes_ (count 0: empty cell)
  };
  std::vector<Bucket> buckets_;               // per cell
  std::vector<std::uint32_t> bucket_nodes_;   // node indices, grouped by cell
  std::vector<float> bucket_values_;          // their values, same order
  long cell_of(const double* measured) const;  // -1 when outside the key box
  GridPoint seed_point(std::uint32_t node) const;
};

}  // namespace chromo::estimation
