#pragma once
// InverseTable: a pre-solved inverse of a ForwardTable in measurement space,
// what FastInverter looks a pixel up in.
//
// Key space: a monotone pseudo-logarithm of each of the first key_dims() =
// min(channels, 4) channel values (the float's exponent plus its mantissa
// read linearly: log2 to within 0.086, exact at powers of two, and computed
// from the bits in two instructions), rotated onto the principal axes of the
// table nodes' keys (the gamut is a thin curved sheet: along its thin
// direction βm and Che change the channels by a few per cent only, and
// unrotated bins would each span the whole βm range), then cut into kBins
// bins per axis between the smallest and largest key of any table node.
// Most of the 48⁴ cells are empty.
//
// Per occupied cell:
//  - a bucket: the table nodes whose predicted values fall in the cell (the
//    search path's seeds; cells next to the gamut's surface share a
//    neighbour's bucket after two dilation passes);
//  - for 4-channel tables, up to kMaxBranches branches of the non-unique
//    inverse at the cell centre: for every connected group (grid-adjacent
//    nodes) of the cell's bucket, bounded LM on the interpolated forward table
//    from the group's best node towards the centre's measurement; distinct
//    solutions (more than 0.25 node apart) whose χ² is within 1 of the best
//    are kept. A branch stores its solution x0 (grid coordinates), the
//    table's prediction m0 there and the pseudo-inverse of the table's 4×4
//    Jacobian at x0 (singular values below 1e-4 of the largest dropped: a
//    parameter the channels barely see there, or a fold of the inverse
//    where two branches meet), so that x ≈ x0 + J⁺·(m − m0) for a
//    measurement m of that cell.
//
// Build: OpenMP over cells (one LM solve per group), ≈ 2-4 s on 2 cores for
// the default table. Cache: load_or_build() keys a file by a hash of the
// forward table's key and values, the bins, the build's settings and the
// format version; a missing file is built and stored; a file that does not
// read back intact (wrong magic, key, sizes, checksum) is rebuilt with a
// warning (never read as a table); writes go to a temporary file renamed into
// place. Tables are also shared within a process (one per key).
//
// Thread rules: immutable after construction; every const member may be
// called from any number of threads.

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "chromo/estimation/forward_table.hpp"

namespace chromo::estimation {

class InverseTable {
 public:
  static constexpr int kBins = 48;
  static constexpr int kMaxBranches = 8;
  static constexpr std::uint32_t kNoCell = 0xffffffffu;

  struct Branch {
    float x0[4];     // grid coordinates of the solution at the cell centre
    float m0[4];     // the forward table's prediction at x0
    float jinv[16];  // row-major (dx/dm); all zero: no linear step (fold)
    bool has_step() const { return jinv[0] != 0 || jinv[5] != 0 || jinv[10] != 0 || jinv[15] != 0; }
  };
  struct Cell {
    std::uint32_t bucket_begin = 0, bucket_count = 0;  // range in bucket_nodes()
    std::uint32_t branch_begin = 0, branch_count = 0;  // range in branches()
  };

  // Builds on `threads` threads (0 = all cores). The table must be non-empty.
  static InverseTable build(std::shared_ptr<const ForwardTable> table, int threads = 0);
  // Loads cache_dir/inverse_table_<key>.bin when intact, else builds and
  // stores it. *rebuilt says which happened; *warning (optional) is set when
  // an existing file had to be rebuilt (and why), cleared otherwise. A
  // process-wide registry returns the same object for the same key while any
  // user holds it.
  static std::shared_ptr<const InverseTable> load_or_build(std::shared_ptr<const ForwardTable> table,
                                                           const std::filesystem::path& cache_dir,
                                                           bool* rebuilt = nullptr, std::string* warning = nullptr,
                                                           int threads = 0);
  static std::uint64_t cache_key(const ForwardTable& table);
  static std::string file_name(std::uint64_t key);  // "inverse_table_<16 hex>.bin"

  int key_dims() const { return key_dims_; }
  // Cell of a measurement (its first key_dims() channels; beyond the key
  // box: the box's edge cell); kNoCell for an empty cell or a non-finite key.
  std::uint32_t cell_of(const float* measured) const;
  // The key-box cell of a measurement (index over all kBins^key_dims() cells,
  // occupied or not); kNoCell for a non-finite key.
  std::uint32_t box_of(const float* measured) const;
  const Cell& cell(std::uint32_t index) const { return cells_[index]; }
  const std::vector<std::uint32_t>& bucket_nodes() const { return bucket_nodes_; }
  const Branch* branches(const Cell& c) const { return branches_.data() + c.branch_begin; }
  std::size_t branch_count() const { return branches_.size(); }
  std::size_t occupied_cells() const { return cells_.size(); }
  // Share of the key box's cells that hold a bucket (for reports).
  double filled_share() const;

 private:
  int key_dims_ = 0;
  float key_mean_[4] = {}, key_axes_[16] = {};  // principal axes of the nodes' keys (rows)
  float key_min_[4] = {}, key_scale_[4] = {};
  void key_of(const float* values, float* key) const;  // pseudo-log, centred, rotated
  std::uint64_t key_ = 0;
  std::vector<std::uint32_t> cell_index_;   // per key-box cell: index into cells_, or kNoCell
  std::vector<Cell> cells_;                 // occupied (and dilated) cells
  std::vector<std::uint32_t> bucket_nodes_; // node indices, grouped by cell
  std::vector<Branch> branches_;

  bool read(const std::filesystem::path& file, std::uint64_t key, std::string* why);
  bool write(const std::filesystem::path& file) const;
};

// The key of one channel value (see above): monotone, ≈ log2(max(v, 1e-4)).
inline float inverse_table_key(float value) {
  const float v = value > 1e-4f ? value : 1e-4f;
  std::uint32_t bits;
  __builtin_memcpy(&bits, &v, sizeof bits);
  return static_cast<float>(bits) * (1.0f / 8388608.0f) - 127.0f;
}

}  // namespace chromo::estimation
