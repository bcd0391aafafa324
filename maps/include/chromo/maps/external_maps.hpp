#pragma once
// External melanin and hemoglobin maps (another device's relative maps, e.g.
// a commercial skin-imaging camera) brought into this model, and compared
// with this project's own 4D search, as the paper's Table 2 does.
//
// 1. "2D mapping": Cm = f(melanin), Ch = g(hemoglobin), βm = 0.7, Che = 0
//    (the 2D model). f and g are MONOTONE functions fitted against the
//    measured albedo: every pixel's measurement is inverted in the 2D model
//    (exhaustive 2D search through the forward table), and log10 Cm (log10 Ch)
//    is regressed on the imported value by weighted isotonic regression
//    (pool-adjacent-violators on the medians of `mapping_bins` quantile bins
//    of the imported value, weighted by pixel count; increasing unless told
//    otherwise), interpolated linearly between bin centres and constant
//    beyond them. Each bin's value is then refitted to the measurement
//    itself: the value (121 log-spaced candidates) minimising the bin's
//    summed robust loss 25·ln(1 + χ²/25) of the 2D model's prediction (the
//    other axis at its current mapping), with pool-adjacent-violators keeping
//    the mapping monotone; two rounds over both axes. The robust loss keeps
//    pixels no parameters explain (tattoo, hair) from steering the mapping.
//    Nothing is assumed about the other device's scale or curve except that
//    it is monotone.
// 2. "augmented": per pixel, all four parameters fitted to the measurement
//    with the mapped (Cm, Ch) as a Gaussian prior in log10 (σ =
//    prior_sigma_log10): χ² of the measurement (the estimator's noise model)
//    + ((log10 Cm − log10 Cm_map)/σ)² + (same for Ch). βm and Che are free
//    (seeded by a scan over βm × Che nodes at the mapped Cm, Ch, then bounded
//    Levenberg-Marquardt on the interpolated table).
// 3. "4D search": the estimator's fast (or exhaustive) 4D inversion, no prior.
//
// Comparison: the first image of the measurement (channels R, G, B) is the
// photograph; each method's maps are relit through the camera under that
// image's illuminant and compared in CIELAB (reconstruction.hpp's
// photo_delta_e94: camera → XYZ by the Ohta ColorChecker fit). Statistics are
// over the pixels where the measurement is measurable (4D estimator flags
// other than non-finite, saturated, dark) and both imported maps are finite;
// the same pixels for all three methods.

#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "chromo/estimation/estimator.hpp"
#include "chromo/session/measurement_file.hpp"
#include "chromo/maps/profile_table.hpp"  // ParameterMaps
#include "chromo/maps/reconstruction.hpp"

namespace chromo::maps {

struct ExternalMaps {
  int width = 0, height = 0;
  std::vector<float> melanin, hemoglobin;  // relative, any scale
};
// Grey images: 8- or 16-bit PNG/TIFF (OpenCV), or an OpenEXR's channel "Y"
// (else its first channel). Throws std::invalid_argument naming the map
// ("melanin: FILE: ...") for an unreadable file or a size mismatch.
ExternalMaps read_external_maps(const std::filesystem::path& melanin, const std::filesystem::path& hemoglobin);

enum class MonotoneDirection { kIncreasing, kDecreasing, kEither };

struct MonotoneMapping {
  bool increasing = true;
  std::vector<double> input;         // knots, strictly increasing
  std::vector<double> output_log10;  // monotone in the direction of `increasing`
  double log10_at(double value) const;  // linear between knots, constant beyond
};
// Weighted isotonic regression of target_log10 on input (see above; bin medians). Throws
// std::invalid_argument for fewer than 2 distinct inputs or mismatched sizes.
MonotoneMapping fit_monotone_mapping(std::span<const double> input, std::span<const double> target_log10,
                                     int bins = 64, MonotoneDirection direction = MonotoneDirection::kEither);
// The same bins, but each bin's value chosen among candidates_log10 to
// minimise the summed loss(item, value) of its items, under the monotonicity
// constraint (pool-adjacent-violators on the bins' loss curves; the direction
// with the lower total loss wins). `loss` is called concurrently.
MonotoneMapping fit_monotone_mapping_to_loss(std::span<const double> input, int bins,
                                             const std::vector<double>& candidates_log10,
                                             const std::function<double(std::size_t item, double value_log10)>& loss,
                                             MonotoneDirection direction = MonotoneDirection::kEither);

struct ImportOptions {
  double prior_sigma_log10 = 0.1;  // augmented fit: how far Cm, Ch may leave the mapping (≈ ±26%)
  int mapping_bins = 64;
  estimation::InverterMethod search_4d = estimation::InverterMethod::kFast;  // kFast or kExhaustive
  int augment_iterations = 20;
  // A relative concentration map grows with the concentration: increasing by
  // default. kEither lets the data choose (it can pick the wrong direction
  // where something the model cannot explain, such as a vein, dominates one end).
  MonotoneDirection direction = MonotoneDirection::kIncreasing;
  int threads = 0;                      // 0 = all cores
  // Optional, width × height: only pixels with a non-zero value enter the
  // statistics (e.g. skin only); fitting and the ΔE94 maps use every pixel.
  std::vector<std::uint8_t> statistics_mask;
  std::filesystem::path cache_dir;      // forward-table cache; empty = estimation::ForwardTable::default_cache_dir()
  bool IsValid(std::string* error) const;
};

struct MethodResult {
  std::string name;                  // "2D mapping", "augmented", "4D search"
  ParameterMaps maps;
  std::vector<float> camera_rgb;     // reconstruction, camera RGB under the photograph's illuminant
  std::vector<double> delta_e94;     // per pixel against the photograph; NaN outside the compared pixels
  DeltaEStats stats;
};

struct ImportResult {
  MonotoneMapping cm_mapping, ch_mapping;
  MethodResult mapped_2d, augmented, search_4d;
  std::vector<std::uint8_t> compared;  // pixels in the statistics
  std::vector<float> photograph_rgb;   // images[0] R, G, B
  std::string photograph_name;
  double seconds_2d = 0, seconds_augmented = 0, seconds_4d = 0;
};

// Throws std::invalid_argument (options, sizes, a measurement without R, G, B
// in its first image) before any work.
ImportResult import_external_maps(const ExternalMaps& external, const session::MeasurementFile& measurement,
                                  const ImportOptions& options);

}  // namespace chromo::maps
