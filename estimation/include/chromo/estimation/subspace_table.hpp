#pragma once
// SubspaceTable: a plan's forward table seen in the few directions that carry
// its signal, so that a fit costs the same for 4 channels as for 27
// (issue 39; SubspaceInverter, subspace_inverter.hpp, is its user).
//
// From a ForwardTable of C channels (what every channel of the plan sees over
// the parameter grid: the plan's illuminants × camera channels through the
// skin model) and a reference σ per channel (the noise, the table's model
// error and the learned discrepancy's diagonal at a typical albedo):
//   whitened   y_c = v_c / σ_c
//   projected  z_k = Σ_c U_kc (y_c − μ_c),  k < kDims
// with μ the nodes' mean whitened vector and U the kDims leading principal
// axes of the nodes' whitened values (C × C covariance, eigen-decomposed).
// Every node's z is stored (kDims floats, zero-padded when C < kDims: then
// the projection is a rotation and loses nothing). Because the skin model's
// four parameters fill a curved four-dimensional sheet, kDims = 8 axes hold
// all but a tiny share of its whitened variance (captured_variance(),
// off_subspace_rms()), so |z(m) − z(x)|² is the fit's χ² at the reference
// weights up to that share, whatever C.
//
// Interpolation (predict()): multilinear on the same grid as the forward
// table, one 8-float vector per node, value and 8 × 4 Jacobian from 16 vector
// loads: no work grows with C.
//
// Build: one pass over the nodes for the covariance, one for the projection
// (OpenMP), ≈ 0.1-0.3 s for 741 k nodes at 27 channels on 2 cores. Not
// cached on disk (it derives from the cached forward table in that time);
// shared within a process by shared().
//
// Thread rules: immutable after construction; every const member may be
// called from any number of threads.

#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "chromo/estimation/forward_table.hpp"

namespace chromo::estimation {

class SubspaceTable {
 public:
  static constexpr int kDims = 8;  // projected dimensions stored per node (one AVX register)

  // reference_sigma: table.channels() values > 0 (albedo units). Throws
  // std::invalid_argument naming the problem (empty table, wrong count,
  // a σ that is not finite and positive).
  SubspaceTable(std::shared_ptr<const ForwardTable> table, std::span<const double> reference_sigma, int threads = 0);
  // One table per (forward table key, reference σ rounded to 1/64 octave) while any user holds it.
  static std::shared_ptr<const SubspaceTable> shared(std::shared_ptr<const ForwardTable> table,
                                                     std::span<const double> reference_sigma, int threads = 0);

  const ForwardTable& forward() const { return *table_; }
  int channels() const { return channels_; }
  // Share of the nodes' whitened variance on the stored axes (1 when C ≤ kDims).
  double captured_variance() const { return captured_variance_; }
  // RMS over the nodes of the whitened values' distance from the subspace (σ units).
  double off_subspace_rms() const { return off_subspace_rms_; }
  const std::vector<double>& reference_sigma() const { return sigma_; }

  // z of a measurement (channels() values, albedo units) into kDims floats.
  void project(const double* measured, float* z) const;
  // The whitened, centred measurement y_c = m_c / σ_c − μ_c (channels() floats).
  void whiten(const double* measured, float* y) const;
  // Stored axes (the first kept_dims() hold principal axes, the rest are zero);
  // axis(k) holds channels() floats.
  int kept_dims() const { return std::min(channels_, kDims); }
  const float* axis(int k) const { return axes_.data() + std::size_t(k) * channels_; }
  // Stored z of node `index` (ForwardTable's node order: offset / channels).
  const float* node(std::size_t index) const { return values_.data() + index * kDims; }
  std::size_t node_index(int i_cm, int i_ch, int i_bm, int i_che) const {
    return table_->node_offset(i_cm, i_ch, i_bm, i_che) / static_cast<std::size_t>(channels_);
  }
  // Multilinear z at grid coordinates x (clamped into the grid): value kDims
  // floats; jacobian (optional) kDims × 4 row-major, d z / d x.
  void predict(const float* x, float* value, float* jacobian) const;

 private:
  std::shared_ptr<const ForwardTable> table_;
  int channels_ = 0;
  std::vector<double> sigma_;
  std::vector<float> scale_;  // 1/σ_c
  std::vector<float> mean_;   // μ_c (whitened)
  std::vector<float> axes_;   // kDims rows of channels_ (zero rows beyond C)
  std::vector<float> values_; // node-major, kDims per node
  std::size_t step_[4] = {};  // nodes between neighbours along each axis
  double captured_variance_ = 1, off_subspace_rms_ = 0;
};

}  // namespace chromo::estimation
