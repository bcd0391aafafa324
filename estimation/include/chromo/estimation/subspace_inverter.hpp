#pragma once
// SubspaceInverter: an inverter whose cost barely grows with the plan's
// channel count (issue 39, item 2). docs/estimation.md "The subspace
// inverter" has its figures.
//
// Per pixel, for order 4 (Cm, Ch, βm, Che free) or 2 (βm = 0.7, Che = 0):
//  1. Project the measurement into the plan's SubspaceTable (whitened by the
//     reference σ, 8 principal directions): O(C) once.
//  2. Start: the pixel's cell of the inverse table (the fast inverter's,
//     keyed on the principal axes of the whitened pseudo-log channels; shared
//     and cached with it), its node bucket scanned in the 8-D subspace; a
//     pixel outside the table a two-level node scan in the subspace; for
//     order 2 the start projected onto the 2D slice.
//  3. Node descent in the subspace, a parabola per axis through the best
//     node's neighbours, then bounded Gauss-Newton in the subspace with the
//     pixel's own weights: with M = Uᵀ D² U = L Lᵀ (U the axes, D the
//     pixel's weights over the reference ones) and the measurement's part off
//     the subspace r⊥, the full weighted χ² is |Lᵀ z(x) − target|² + const
//     (set up once per pixel in O(C); then 8 values and an 8 × 4 Jacobian
//     per point, whatever C).
//  4. Polish: bounded LM on the full weighted residual (the forward table's C
//     channels), at most Options::polish_steps, which stops itself when the
//     subspace fit already sits at the minimum (1-3 iterations on average);
//     χ² is the full weighted sum, as the exhaustive search's.
//  5. A 4D fit above Options::fallback_chi2 (the Estimator caps it at its own
//     flag threshold, as for the fast inverter) also runs the fast
//     inverter's search path in the full channel space (bucket node,
//     descent, ≤ 20 LM steps) and the smaller χ² wins: a pixel near or
//     beyond the flag threshold gets the same search as today.
// The exhaustive search (inverter.hpp) stays the accuracy reference.
//
// Thread rules: immutable after construction; fit() may be called from any
// number of threads.

#include <filesystem>
#include <memory>
#include <span>
#include <string>

#include "chromo/estimation/inverse_table.hpp"
#include "chromo/estimation/inverter.hpp"
#include "chromo/estimation/subspace_table.hpp"

namespace chromo::estimation {

struct SubspaceInverterOptions {
  int subspace_steps = 12;      // at most this many Gauss-Newton iterations in the subspace
  int polish_steps = 20;        // at most this many on the full weighted residual
  // A polished fit above this χ² also takes the full-channel search path;
  // the Estimator caps it at its flag threshold. ∞: never.
  double fallback_chi2 = 1e30;
  bool IsValid(std::string* error) const;
};

class SubspaceInverter : public Inverter {
 public:
  using Options = SubspaceInverterOptions;
  // subspace: built on `table` (same key); inverse: the fast inverter's
  // table for it (InverseTable::load_or_build). Throws std::invalid_argument
  // for a mismatch or invalid options.
  SubspaceInverter(std::shared_ptr<const ForwardTable> table, std::shared_ptr<const SubspaceTable> subspace,
                   std::shared_ptr<const InverseTable> inverse, Options options = {});
  std::string_view name() const override { return "subspace"; }
  Fit fit(const double* measured, const double* weight, int order) const override;
  const Options& options() const { return options_; }
  const SubspaceTable& subspace() const { return *subspace_; }

 private:
  Options options_;
  std::shared_ptr<const SubspaceTable> subspace_;
  std::shared_ptr<const InverseTable> inverse_;
  // Level-1 nodes of the out-of-table scan: every 8th Cm and Ch node, every
  // 4th βm and Che node, their z contiguous.
  std::vector<std::array<int, 4>> coarse_nodes_;
  std::vector<float> coarse_z_;
  std::array<int, 4> start_node(const float* z, const double* measured) const;
  std::array<int, 4> descend_nodes(const float* z, std::array<int, 4> at, int dims, bool diagonal) const;
  std::array<int, 4> coarse_scan(const float* z) const;
  Fit search_full(const double* measured, const double* weight, int order) const;
};

}  // namespace chromo::estimation
