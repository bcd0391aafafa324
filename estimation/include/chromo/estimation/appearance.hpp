#pragma once
// AppearanceTable: what skin parameters look like under the report's
// reference illuminants (spectral::relight_illuminants(): the six LED types
// of the virtual lab and D65): CIELAB per illuminant, each with its own white
// (MODEL.md "Colour"), for the auto model's order rule (estimator.hpp, step 3).
//
// It is a ForwardTable whose "camera" is the CIE 1931 2° observer: channel
// 3·l + i is X/Xn, Y/Yn or Z/Zn (i = 0, 1, 2) under illuminant l (the
// camera normalisation makes a white of albedo 1 give 1, i.e. the
// illuminant's white), 21 channels on a coarser grid than the measurement
// table's (kGrid: 21×21×11×11 over the same ranges and spacings, 4.5 MB, so
// that its lookups stay in cache: on the measurement table's own grid, 62
// MB, the order rule cost more than the two fits). A measurement-grid
// coordinate maps to it by one factor per axis ((n_app − 1)/(n_meas − 1)),
// so a fit's grid coordinates index it directly. Lab follows by the CIE
// formula; its Jacobian by the chain rule through the multilinear
// interpolation. Interpolation error: docs/estimation.md ("Per-pixel
// decisions").
//
// load_or_build caches it on disk like any ForwardTable (key from the
// observer × illuminants and the grid); shared() keeps one per (measurement
// grid, cache folder) in the process while any Estimator holds it.
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
  static constexpr TableGrid kGrid{21, 21, 11, 11};

  // The 21 channels (X, Y, Z under each reference illuminant) as a
  // measurement set whose camera is the CIE observer; the noise fields are
  // unused (the table is a prediction, never fitted).
  static MeasurementSet reference_set();

  // From a table of reference_set() on any valid grid, indexed by
  // coordinates of `measurement_grid` (std::invalid_argument for another
  // channel count or an invalid grid).
  AppearanceTable(std::shared_ptr<const ForwardTable> table, const TableGrid& measurement_grid);
  // ForwardTable::load_or_build(reference_set(), kGrid, cache_dir) (empty
  // cache_dir: ForwardTable::default_cache_dir()), indexed by coordinates of
  // measurement_grid.
  static std::shared_ptr<const AppearanceTable> load_or_build(const TableGrid& measurement_grid,
                                                              const std::filesystem::path& cache_dir, int threads = 0);
  // As load_or_build, but one instance per (measurement grid, cache folder)
  // while any holder keeps it.
  static std::shared_ptr<const AppearanceTable> shared(const TableGrid& measurement_grid,
                                                       const std::filesystem::path& cache_dir);

  const ForwardTable& table() const { return *table_; }

  // CIELAB under every reference illuminant at x, in coordinates of the
  // measurement grid: lab[3·l + {0,1,2}] = L*, a*, b* under illuminant l.
  // jacobian (optional): kChannels × 4, row-major, d lab / d x.
  void lab(const GridPoint& x, double* lab, double* jacobian = nullptr) const;

  // The same at x with what a linearised Lab difference needs: the
  // normalised tristimulus values and the slope of the CIE f at each.
  struct Point {
    double lab[kChannels], jacobian[kChannels * 4], xyz[kChannels], f_slope[kChannels];
  };
  void at(const GridPoint& x, Point& out) const;
  // Normalised X/Xn, Y/Yn, Z/Zn per illuminant at x (no Lab: no cube roots).
  void xyz(const GridPoint& x, double* xyz) const;
  // ΔE*ab between `from` and the tristimulus values xyz, linearised at
  // `from` (exact to first order; the rule compares differences of a few
  // ΔE), for illuminant l.
  static double linear_delta_e(const Point& from, const double* xyz, int l);

 private:
  std::shared_ptr<const ForwardTable> table_;
  std::array<double, 4> scale_{};  // appearance-grid units per measurement-grid unit
};

}  // namespace chromo::estimation
