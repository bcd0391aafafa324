#pragma once
// InverseTable: a pre-solved inverse of a ForwardTable in measurement space,
// what FastInverter looks a pixel up in.
//
// Key space: a monotone pseudo-logarithm of every channel value (the
// float's exponent plus its mantissa read linearly: log2 to within 0.086,
// exact at powers of two, and computed from the bits in two instructions),
// rotated onto the principal axes of the table nodes' keys (the gamut is a
// thin curved sheet: along its thin direction βm and Che change the channels
// by a few per cent only, and unrotated bins would each span the whole βm
// range), then cut into kBins bins per axis between the smallest and largest
// key of any table node. Most of the 48⁴ cells are empty.
//  - Up to four channels: key_dims() = channels, the rotation is square.
//  - More channels (a multispectral plan's 18-24 and beyond): each channel's
//    pseudo-log is first divided by its relative noise σ_c/value
//    (InverseTableSettings::channel_relative_sigma: the noise-whitened
//    measurement, in which every channel's noise is equal), and the key is
//    the projection on the kMaxKeyDims = 4 principal axes of the nodes'
//    whitened keys: the measurement's principal subspace. The 4-D skin
//    model fills a 4-D manifold of the C-dimensional measurement space, so
//    four components hold nearly all of its variance whatever C (the
//    build reports the share, captured_variance()), and the key, the cell
//    index and its memory stay those of a 4-channel table. Noise off the
//    subspace does not move the key (and the noise along it is averaged
//    over all channels). Such tables hold buckets only (FastInverter's
//    search path seeds from them); the branches, the empty cells' pre-solved
//    fits and the 2D fits below are built for 4-channel tables.
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
// Per empty cell (for 4-channel tables with
// InverseTableSettings::presolve_empty_cells): the fill points it at the
// nearest occupied cell along one key axis (up to 2/4/16/48 bins, widest axis
// first: noisy pixels lie off the thin sheet by many bins of its thin axes),
// whose bucket and branches it shares, and it gets one branch of its own:
// the bounded fit at the centre of its block (1×1×4×8 bins along the key
// axes, widest first) with the channels' relative noise of the settings. Off
// the sheet the exact inverse lies outside the parameter box, so that fit sits
// on a bound face (Che = 0, a βm bound, ...); its pseudo-inverse is the
// weighted one of the Jacobian without the held coordinates' columns (their
// rows are zero), so x0 + J⁺·(m − m0) is the least-squares step along that
// face, and a noisy pixel starts on its own face and fold instead of a
// neighbour's. One branch is shared by the cells of a block; a cell of the
// index per (block, neighbour) pair carries the neighbour's ranges and it.
//
// Per cell, for 4-channel tables: the 2D model's pre-solved fit (the slice
// βm = 0.7, Che = 0, free Cm and Ch), as a Branch whose βm and Che rows of
// J⁺ are zero: the global slice fit (every slice node, then LM) at the cell
// centre (an empty cell: its block's centre) with the channels' relative
// noise of the settings (four channels weigh two parameters, so the weights
// move the solution). FastInverter's order-2 fit starts there instead of
// walking the slice's nodes from the bucket's best 4D node.
//
// Build (src/inverse_table_build.cpp): OpenMP over cells (one LM solve per
// group, and the cell's 2D fit), then over the empty cells' blocks (the fast
// fit on the occupied cells' branches, polished by LM, and the block's 2D
// fit), ≈ 2.5 s on 2 cores for the default table. Cache: load_or_build() keys a file by a hash of the
// forward table's key and values, the bins, the build's settings and the
// format version; the file is a files/binary_cache.hpp cache (magic
// "CHROMOIT"); a missing file is built and stored; a file that does not read
// back intact (wrong magic, version, key, length, checksum, sizes) is rebuilt
// with a warning saying why (never read as a table); writes are durable. Tables are also shared within a process (one per key).
//
// Thread rules: immutable after construction; every const member may be
// called from any number of threads.

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "chromo/estimation/forward_table.hpp"

namespace chromo::estimation {

// An InverseTable's build settings beyond its forward table (part of its
// cache key).
struct InverseTableSettings {
  // Give the empty cells the fill reaches their own pre-solved branch (see
  // InverseTable): noisy pixels then start on their own bound face.
  bool presolve_empty_cells = true;
  // The camera noise σ of the four channels relative to each other (any
  // common scale, e.g. σ/value at a typical skin albedo): the weights of the
  // 2D fits and of the empty cells' pre-solved fits, whose bound face depends on them (a noisy
  // difference channel, the method's blue one with ≈ 10× the others' relative
  // noise, lets a fit leave that channel and move along another face). Only the
  // ratios count, rounded to half-octaves of the smallest (quantised_sigma())
  // so that sessions whose noise differs a little share one cached table.
  // All zero: equal relative noise (the Estimator fills them in from its
  // measurement set's noise models, from_noise()).
  std::array<double, 4> relative_sigma = {};
  // Tables of more than four channels: every channel's relative noise
  // (σ/value, any common scale), which whitens the key (see above); rounded
  // to half-octaves like relative_sigma (quantised_channel_sigma()). Empty:
  // equal noise. Ignored for tables of up to four channels.
  std::vector<double> channel_relative_sigma;
  bool IsValid(std::string* error) const;
  // relative_sigma from a set's noise models (σ/value at albedo 0.2 per
  // channel; the first four channels).
  static std::array<double, 4> from_noise(const MeasurementSet& set);
  // These settings for `set`: a 4-channel set's relative_sigma
  // from_noise(set) where it is all zero, a set of more than four channels'
  // channel_relative_sigma from its noise models where it is empty (what the
  // Estimator builds); otherwise unchanged.
  InverseTableSettings completed_for(const MeasurementSet& set) const;
  // The ratios the build weighs with: 2^(round(2·log2(σ_c/σ_min))/2), or all 1.
  std::array<double, 4> quantised_sigma() const;
  // The same rounding of channel_relative_sigma for `channels` channels (all 1
  // when it is empty or has another length).
  std::vector<double> quantised_channel_sigma(int channels) const;
};

class InverseTable {
 public:
  static constexpr int kBins = 48;
  static constexpr int kMaxKeyDims = 4;  // the key's dimensions for any channel count
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
    // An empty cell's own pre-solved branch (index in branches(), after the
    // neighbour's range), or kNoCell.
    std::uint32_t presolved_branch = kNoCell;
    // The 2D model's pre-solved fit (index in branches()), or kNoCell.
    std::uint32_t slice_branch = kNoCell;
  };

  // Builds on `threads` threads (0 = all cores). The table must be non-empty.
  static InverseTable build(std::shared_ptr<const ForwardTable> table, int threads = 0,
                            const InverseTableSettings& settings = {});
  // Loads cache_dir/inverse_table_<key>.bin when intact, else builds and
  // stores it. *rebuilt says which happened; *warning (optional) is set when
  // an existing file had to be rebuilt (and why), cleared otherwise. A
  // process-wide registry returns the same object for the same key while any
  // user holds it.
  static std::shared_ptr<const InverseTable> load_or_build(std::shared_ptr<const ForwardTable> table,
                                                           const std::filesystem::path& cache_dir,
                                                           bool* rebuilt = nullptr, std::string* warning = nullptr,
                                                           int threads = 0, const InverseTableSettings& settings = {});
  // Throws std::invalid_argument for invalid settings.
  static std::uint64_t cache_key(const ForwardTable& table, const InverseTableSettings& settings = {});
  static std::string file_name(std::uint64_t key);  // "inverse_table_<16 hex>.bin"
  // The cache key this table was built or loaded under (cache_key above).
  std::uint64_t key() const { return key_; }

  int key_dims() const { return key_dims_; }
  int key_channels() const { return key_channels_; }  // the forward table's channel count
  // Share of the nodes' whitened key variance on the key's axes (1 for tables
  // of up to four channels).
  double captured_variance() const { return captured_variance_; }
  // Cell of a measurement (all key_channels() values; beyond the key box:
  // the box's edge cell); kNoCell for an empty cell or a non-finite key.
  std::uint32_t cell_of(const float* measured) const;
  // The key-box cell of a measurement (index over all kBins^key_dims() cells,
  // occupied or not); kNoCell for a non-finite key.
  std::uint32_t box_of(const float* measured) const;
  // The cell a key-box cell (box_of()) holds or points at, or kNoCell.
  std::uint32_t cell_at(std::uint32_t box) const { return box < cell_index_.size() ? cell_index_[box] : kNoCell; }
  const Cell& cell(std::uint32_t index) const { return cells_[index]; }
  const std::vector<std::uint32_t>& bucket_nodes() const { return bucket_nodes_; }
  const Branch* branches(const Cell& c) const { return branches_.data() + c.branch_begin; }
  const Branch& branch(std::uint32_t index) const { return branches_[index]; }
  std::size_t branch_count() const { return branches_.size(); }  // the empty cells' and the 2D fits included
  // Cells holding table nodes (numbered first), and the empty cells' own
  // cells after them (one per block and neighbour, see above).
  std::size_t occupied_cells() const { return occupied_cells_; }
  std::size_t presolved_empty_cells() const { return cells_.size() - occupied_cells_; }
  // Share of the key box's cells that hold a bucket (for reports).
  double filled_share() const;

 private:
  int key_dims_ = 0, key_channels_ = 0;
  double captured_variance_ = 1;
  std::vector<float> key_whiten_;  // per channel: 1/relative σ (1 for up to four channels)
  std::vector<float> key_mean_;    // per channel: mean whitened key of the nodes
  std::vector<float> key_axes_;    // key_dims_ rows of key_channels_: principal axes of the nodes' keys
  float key_min_[4] = {}, key_scale_[4] = {};
  void key_of(const float* values, float* key) const;  // pseudo-log, whitened, centred, rotated
  std::uint64_t key_ = 0;
  std::vector<std::uint32_t> cell_index_;   // per key-box cell: index into cells_, or kNoCell
  std::vector<Cell> cells_;                 // occupied cells, then the pre-solved empty cells
  std::size_t occupied_cells_ = 0;
  std::vector<std::uint32_t> bucket_nodes_; // node indices, grouped by cell
  std::vector<Branch> branches_;

  // Measurement at the centre of the key-box cell with (fractional) bins `bin`.
  std::array<double, 4> box_centre(std::array<float, 4> bin) const;
  // Gives every empty cell the fill reached a pre-solved branch and 2D fit (4 channels).
  void presolve_empty_cells(std::shared_ptr<const ForwardTable> table, const std::vector<std::uint32_t>& own_cell_index,
                            const std::array<double, 4>& relative_sigma, int threads);

  // The cache file's payload, and back (false with *why when it is inconsistent).
  std::vector<std::uint8_t> encode() const;
  bool decode(std::span<const std::uint8_t> payload, std::uint64_t key, std::string* why);
};

// The key of one channel value (see above): monotone, ≈ log2(max(v, 1e-4)).
inline float inverse_table_key(float value) {
  const float v = value > 1e-4f ? value : 1e-4f;
  std::uint32_t bits;
  __builtin_memcpy(&bits, &v, sizeof bits);
  return static_cast<float>(bits) * (1.0f / 8388608.0f) - 127.0f;
}

}  // namespace chromo::estimation
