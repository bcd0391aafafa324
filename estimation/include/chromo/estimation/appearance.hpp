#pragma once
// AppearanceTable: what skin parameters look like under the report's
// reference illuminants (spectral::relight_illuminants(): the six LED types
// of the virtual lab and D65): CIELAB per illuminant, each with its own white
// (MODEL.md "Colour"), for the auto model's order rule (estimator.hpp, step 3).
//
// It is a ForwardTable whose "camera" is the CIE 1931 2° observer: channel
// 3·l + i is X/Xn, Y/Yn or Z/Zn (i = 0, 1, 2) under illuminant l (the
// camera normalisation makes a white of albedo 1 give 1, i.e. the
// illuminant's white), 21 channels on the measurement table's grid, so a
// fit's grid coordinates index it directly. Lab follows from those by the
// CIE formula; its Jacobian by the chain rule through the same multilinear
// interpolation. Interpolation error: ≈ 0.017 mean ΔE94 under D65 on the
// default grid (docs/estimation.md, "Table grid").
//
// Size: 21 floats a node (62 MB on the default grid); load_or_build caches it
// on disk like any ForwardTable (key from the observer × illuminants and the
// grid), and shared() keeps one per (grid, cache folder) in the process while
// any Estimator holds it.
//
// Thread rules: immutable after construction; every const member may be
// called from any number of threads; shared() is thread-safe.

#include <filesystem>
#include <memory>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/measurement.hpp"

namespace chromo::estimation {

class AppearanceTable {
 public:
  static constexpr int kIlluminants = 7;            // six LED types, then D65
  static constexpr int kChannels = 3 * kIlluminants;

  // The 21 channels (X, Y, Z under each reference illuminant) as a
  // measurement set whose camera is the CIE observer; the noise fields are
  // unused (the table is a prediction, never fitted).
  static MeasurementSet reference_set();

  // From a table of reference_set() (std::invalid_argument for any other
  // channel count).
  explicit AppearanceTable(std::shared_ptr<const ForwardTable> table);
  // ForwardTable::load_or_build(reference_set(), grid, cache_dir) (empty
  // cache_dir: ForwardTable::default_cache_dir()).
  static std::shared_ptr<const AppearanceTable> load_or_build(const TableGrid& grid,
                                                              const std::filesystem::path& cache_dir, int threads = 0);
  // As load_or_build, but one instance per (grid, cache folder) while any
  // holder keeps it.
  static std::shared_ptr<const AppearanceTable> shared(const TableGrid& grid, const std::filesystem::path& cache_dir);

  const ForwardTable& table() const { return *table_; }

  // CIELAB under every reference illuminant at grid point x: lab[3·l + {0,1,2}]
  // = L*, a*, b* under illuminant l. jacobian (optional): kChannels × 4,
  // row-major, d lab / d x.
  void lab(const GridPoint& x, double* lab, double* jacobian = nullptr) const;

 private:
  std::shared_ptr<const ForwardTable> table_;
};

}  // namespace chromo::estimation
