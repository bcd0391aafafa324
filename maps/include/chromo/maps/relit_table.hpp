#pragma once
// RelitTable: the skin model's camera RGB (white = 1) under a list of
// illuminants, tabulated on the forward table's 4D grid (an
// estimation::ForwardTable of three channels per illuminant) and interpolated
// multilinearly per pixel: the relit comparison's fast path
// (estimate_report.hpp, RelitModel::kTable). One interpolation of 16 corners
// replaces one evaluation of the 81-wavelength model per pixel.
//
// Error against the exact model: that of the forward table the inverters fit
// on (docs/estimation.md: mean ΔE94 ≈ 0.017 under D65 over the full
// parameter range); on the relit comparison's statistics it is measured by
// bench/estimate_stages_bench.cpp and checked by tests/maps/relit_table_test.cpp.
// The table is cached like the forward table (ForwardTable::load_or_build,
// keyed by camera × illuminants, grid and model), so a session under the same
// lights loads it.
//
// Thread rules: immutable after construction; rgb() from any thread.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <vector>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::maps {

class RelitTable {
 public:
  // cache_dir empty: built in memory only. Throws std::invalid_argument for
  // no illuminant or an illuminant a camera channel sees nothing under.
  RelitTable(const spectral::CameraSensitivity& camera, std::span<const spectral::Spectrum> illuminants,
             const estimation::TableGrid& grid, const std::filesystem::path& cache_dir, int threads = 0);

  // The cache key of the table these arguments make (a table made earlier,
  // e.g. during capture, serves a comparison whose key equals its key()).
  static std::uint64_t cache_key(const spectral::CameraSensitivity& camera,
                                 std::span<const spectral::Spectrum> illuminants, const estimation::TableGrid& grid);
  std::uint64_t key() const { return table_->key(); }

  std::size_t illuminants() const { return illuminants_; }
  // Camera RGB of `p` under each illuminant: out[i] for illuminant i.
  void rgb(const estimation::SkinParameters& p, Eigen::Vector3d* out) const;
  // The same for many: [illuminant][parameter set], on `threads` threads (0 = all cores).
  std::vector<std::vector<Eigen::Vector3d>> rgb(std::span<const estimation::SkinParameters> parameters,
                                                int threads = 0) const;
  bool rebuilt() const { return rebuilt_; }  // not in the disk cache (or no cache)
  const estimation::ForwardTable& table() const { return *table_; }

 private:
  std::size_t illuminants_ = 0;
  std::shared_ptr<const estimation::ForwardTable> table_;
  bool rebuilt_ = true;
};

}  // namespace chromo::maps
