#pragma once
// ForwardTable: the skin model's predicted measurement vector (one value per
// channel of a MeasurementSet) on a 4D grid of (Cm, Ch, βm, Che), with
// multilinear interpolation (and its Jacobian) between nodes.
//
// Grid (TableGrid, justified in docs/estimation.md): Cm and Ch log-spaced over
// their MODEL.md ranges, because the albedo changes with the logarithm of a
// concentration far more evenly than with the concentration (Cm = 0.001 and
// 0.01 differ more in colour than 0.4 and 0.5); βm and Che linear. βm has
// 10k+1 nodes and Che starts at 0, so the 2D model (βm = 0.7, Che = 0) lies on
// a slice of nodes and is interpolated in 2D exactly as in 4D.
//
// Coordinates: inverters work in "grid coordinates" x = continuous node index
// per axis (x[0] for Cm ... x[3] for Che), in [0, n-1]. Bounds are then boxes.
//
// Build: the epidermis depends on (Cm, βm, Che) only and the dermis on Ch only,
// so the build evaluates the slab once per epidermis node and the dipole once
// per Ch node, then combines them per node and projects onto the channel
// weights with one matrix product per epidermis node (OpenMP over epidermis
// nodes). Numbers equal SkinModel::albedo to rounding.
//
// Cache: load_or_build() keys a file by a 64-bit hash of everything the table
// depends on: the channel weights (camera × illuminants), the grid, the
// format version and the model itself (its albedo at fixed probe parameters,
// so any change to the model's code or data changes the key). The file is a
// files/binary_cache.hpp cache (magic "CHROMOFT"; payload: the five
// dimensions as int32, then the values as float): one that is missing,
// truncated, corrupted or of another key or version is rebuilt, and writes are
// durable, so concurrent builders never see half a table.
//
// Thread rules: a ForwardTable is immutable after construction; every const
// member may be called from any number of threads.

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/skin_parameters.hpp"

namespace chromo::estimation {

struct TableGrid {
  int cm_nodes = 41;
  int ch_nodes = 41;
  int bm_nodes = 21;   // must be 10k+1 so that βm = 0.7 is a node
  int che_nodes = 21;
  bool IsValid(std::string* error) const;
  std::size_t node_count() const {
    return static_cast<std::size_t>(cm_nodes) * ch_nodes * bm_nodes * che_nodes;
  }
};

using GridPoint = std::array<double, 4>;  // grid coordinates (Cm, Ch, βm, Che)

class ForwardTable {
 public:
  ForwardTable() = default;  // empty; use build() or load_or_build()
  // Builds on `threads` threads (0 = all cores). Throws std::invalid_argument
  // for an invalid grid or measurement set.
  static ForwardTable build(const MeasurementSet& set, const TableGrid& grid, int threads = 0);

  // Loads cache_dir/forward_table_<key>.bin if it is intact and keyed to these
  // inputs, otherwise builds and stores it. *rebuilt says which happened.
  static std::shared_ptr<const ForwardTable> load_or_build(const MeasurementSet& set, const TableGrid& grid,
                                                           const std::filesystem::path& cache_dir,
                                                           bool* rebuilt = nullptr, int threads = 0);
  // The cache key of (set, grid); what load_or_build names the file after.
  static std::uint64_t cache_key(const MeasurementSet& set, const TableGrid& grid);
  // $CHROMO_CACHE_DIR, else $XDG_CACHE_HOME/chromosphere, else ~/.cache/chromosphere.
  static std::filesystem::path default_cache_dir();

  const TableGrid& grid() const { return grid_; }
  int channels() const { return channels_; }
  std::uint64_t key() const { return key_; }
  std::array<int, 4> nodes() const { return {grid_.cm_nodes, grid_.ch_nodes, grid_.bm_nodes, grid_.che_nodes}; }

  GridPoint to_grid(const SkinParameters& p) const;   // clamped into the grid
  SkinParameters from_grid(const GridPoint& x) const;
  double node_value(int axis, int index) const;        // parameter value of a node

  // Stored values of one node (channels() floats).
  const float* node(int i_cm, int i_ch, int i_bm, int i_che) const {
    return values_.data() + node_offset(i_cm, i_ch, i_bm, i_che);
  }
  std::size_t node_offset(int i_cm, int i_ch, int i_bm, int i_che) const {
    return ((((static_cast<std::size_t>(i_bm) * grid_.che_nodes + i_che) * grid_.cm_nodes + i_cm) * grid_.ch_nodes) +
            i_ch) * channels_;
  }
  const std::vector<float>& values() const { return values_; }

  // Multilinear interpolation at x (clamped into the grid). value: channels()
  // doubles. jacobian (optional): channels() × 4, row-major, d value / d x.
  void predict(const GridPoint& x, double* value, double* jacobian = nullptr) const;

 private:
  TableGrid grid_;
  int channels_ = 0;
  std::uint64_t key_ = 0;
  std::vector<float> values_;
};

}  // namespace chromo::estimation
