#pragma once
// An estimation's output folder, written the same way by `chromo estimate`
// (MEASUREMENT.json or a stored session) and by chromod's on-line estimator:
//
//   maps.exr      FLOAT channels Cm, Ch, Bm, Che, residual, order, flags (pixel_flags.hpp);
//                 a polarised session adds surface and highlight (docs/maps.md)
//   maps.ome.tiff the same channels as float32 OME-TIFF, names and units in its
//                 OME-XML (ome_tiff.hpp), for Fiji, napari and Python
//   polarisation.png  a polarised session's panel diffuse | surface | combined
//   cm.png ch.png bm.png che.png residual.png   false colour with a colour bar
//   flags.png order.png                         categorical with a legend
//   summary.json  method, model, size, channels, timings_s, pixels_per_second,
//                 residual statistics, order_counts, flag_counts, and what the
//                 caller adds (input, table, registration, relit ΔE94, ...)
//
// Files go through a FileCommit: the caller decides how a file becomes
// durable (chromod: temp + fsync + rename + fsync-dir, files/durable_file.hpp;
// the CLI: every file to a temporary name first, all renamed at the end).
//
// estimate_captures() is the whole estimation of any plan's captures
// (method_measurement.hpp's one builder → forward table from the disk cache →
// estimation::Estimator tile by tile on options.threads → the spatial second pass →
// relit ΔE94 against the captured photographs (the reconstruction from a
// RelitTable by default) → the folder above); the daemon and `chromo estimate
// SESSION_DIR` both call it, so they give the same maps for the same frames.
//
// Thread rules: free functions; the estimator runs on its own threads.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <optional>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/files/float_image.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/session/method_measurement.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromo/maps/relit_table.hpp"
#include "chromo/estimation/spatial_flags.hpp"
#include "chromo/estimation/skin_refit.hpp"

namespace chromo::maps {

// Makes `final_path` hold what `produce` writes to the temporary path it is given.
using FileCommit = std::function<void(const std::filesystem::path& final_path,
                                      const std::function<void(const std::filesystem::path& temporary)>& produce)>;

struct EstimateReport {
  std::string method, model;
  int width = 0, height = 0;
  std::vector<std::string> channel_names;
  std::span<const estimation::PixelEstimate> estimates;
  estimation::EstimateSummary summary;
  std::vector<std::pair<std::string, double>> timings_s;  // in order; "estimate" is summary.seconds
  nlohmann::ordered_json extra;  // members added to summary.json (an object; null: none)
  // Channels after "flags" in maps.exr (a polarised session's "surface" and
  // "highlight", docs/maps.md), width × height each.
  std::vector<std::pair<std::string, std::vector<float>>> extra_channels;
  double map_pixel_mm = 0;  // one map pixel's width on the subject (0: unknown): the previews' scale bar
  // Further PNG files written after the previews (name, encoded bytes).
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> extra_pngs;
};

// Each measurement channel's signal-to-noise ratio by its noise model
// (measurement.hpp: σ² = read_sigma² + shot_coefficient·a + white_coefficient·a²): on the white
// reference (a = ρ_white) and on the skin, a = the channel's mean over the
// pixels the estimator explained (flag 0; NaN when none). summary.json's
// "snr" (`docs/formats/session.md`). A pure function.
struct ChannelSnr {
  std::string channel;
  double white = 0, skin = 0, skin_albedo = 0;
  std::size_t skin_pixels = 0;
};
std::vector<ChannelSnr> channel_snr(const estimation::MeasurementSet& set, std::span<const float> measured,
                                    std::span<const estimation::PixelEstimate> estimates, double white_reflectance);

// Writes the folder's files (the directory must exist) and returns
// summary.json's text. writer_threads (0 = all cores, 1 = one): the previews
// are drawn and PNG-encoded in parallel while maps.exr is compressed on
// OpenEXR's pool (files::ExrWriteOptions); `commit` is still called for one
// file at a time, from the calling thread, in the order listed above.
// maps_written (optional): set to maps.exr's channels as written (the
// common view reads them from memory instead of decoding the file again).
std::string write_estimate_report(const std::filesystem::path& dir, const EstimateReport& report,
                                  const FileCommit& commit, int writer_threads = 0,
                                  std::shared_ptr<const files::FloatImage>* maps_written = nullptr);

// ΔE94 of the reconstruction against one captured photograph.
struct RelitComparison {
  std::string illuminant;  // "D65'", "W57", "W57+blue"
  DeltaEStats delta_e94;
  // Over the same pixels, what the photograph's own noise alone gives
  // (photograph_noise_delta_e94_map; absent for a photograph of unknown
  // noise). A dim photograph (the W57 capture of the metered plan: W57 at a
  // few percent of its drive) is mostly noise, so its delta_e94 says little
  // about the maps; beyond_noise_rms does:
  //   √max(0, rms(delta_e94)² − rms(photograph_noise)²),
  // the part of the difference the photograph's noise does not account for
  // (model, estimate and light errors together). The noise is the
  // estimator's noise model of the capture, which on the virtual lab's
  // cameras overestimates it (the floor exceeds the whole difference for
  // dim photographs, which independent noise cannot do; not yet explained,
  // suspected: the white's measured variance includes the sensor's fixed
  // pattern, which the albedo cancels — docs/calibration.md §6): read
  // block_means first.
  std::optional<DeltaEStats> photograph_noise;
  double beyond_noise_rms = std::numeric_limits<double>::quiet_NaN();
  // ΔE94 of block means (RelitComparisonOptions::block_cells² cells, linear
  // camera RGB of the explained pixels of each block, blocks at least half
  // explained): the photograph's noise averages out, the systematic part
  // (a wrong light, the model's floor) stays. Absent without image_width.
  std::optional<DeltaEStats> block_means;
};
// How the reconstruction's camera RGB is computed.
//  kTable: interpolated in a RelitTable (relit_table.hpp) of the
//          photographs' illuminants on `grid`, cached in cache_dir (empty: in
//          memory only): one 16-corner interpolation per pixel;
//  kExact: the skin model evaluated per pixel (81 wavelengths): ≈ 5× the
//          comparison's time at 5 MP; the table moves its statistics by
//          ≤ 0.004 ΔE94 (bench/estimate_stages_bench.cpp, bench/README.md).
enum class RelitModel { kExact, kTable };
std::string_view relit_model_name(RelitModel model);  // "exact", "table"
struct RelitComparisonOptions {
  RelitModel model = RelitModel::kTable;
  estimation::TableGrid grid;
  std::filesystem::path cache_dir;
  int threads = 0;  // 0 = all cores
  int image_width = 0;   // the estimates' row length, for the block means (0: none)
  int block_cells = 8;   // a block's side, cells
  // kTable: a table made earlier (prepare_tables, during capture), used
  // where its key is the photographs' (RelitTable::cache_key); else one is
  // loaded or built.
  std::shared_ptr<const RelitTable> prepared;
};
// Over explained pixels (flag kExplained) with a finite photograph.
std::vector<RelitComparison> compare_with_photographs(std::span<const estimation::PixelEstimate> estimates,
                                                      const std::vector<session::Photograph>& photographs,
                                                      const spectral::CameraSensitivity& camera,
                                                      const RelitComparisonOptions& options = {});

// summary.json's "registration": one object per registered capture (a JSON
// value for the report's file edge).
nlohmann::ordered_json registration_report(std::span<const session::RegistrationReport> registration);

// summary.json's "neighbourhood" object: which parts of the spatial second
// pass ran (spatial_flags.hpp) and what they changed.
nlohmann::ordered_json neighbourhood_report(bool flags, bool order_pooling,
                                            const estimation::NeighbourhoodSummary& summary);

// summary.json's "skin_denoise": whether the multi-pixel estimate ran
// (options empty: off), its options and, when it ran, what it re-fitted.
nlohmann::ordered_json skin_denoise_report(const std::optional<estimation::SkinDenoiseOptions>& options,
                                           const estimation::SkinRefit* refit);

// The estimator options a session's estimation starts from: EstimatorOptions'
// defaults with the model's learned discrepancy on real skin
// (estimation::ModelDiscrepancy::standard(), docs/estimation.md "Real skin").
estimation::EstimatorOptions default_estimator_options();

struct MethodEstimationOptions {
  // method (default fast), model (default auto), threads, the learned discrepancy
  estimation::EstimatorOptions estimator = default_estimator_options();
  // The spatial second pass after the per-pixel estimate, as `chromo
  // estimate` by default: neighbourhood flags (code 7) and the model order
  // pooled over 7×7 windows (model auto). Neither part: no second pass.
  estimation::NeighbourhoodOptions neighbourhood;
  // The multi-pixel estimate between the per-pixel pass and the spatial pass
  // (estimation/skin_refit.hpp; `chromo estimate --skin-denoise`, chromod's
  // estimation.skin_denoise); empty: off, the maps are the per-pixel pass's.
  std::optional<estimation::SkinDenoiseOptions> skin_denoise;
  estimation::TableGrid grid;
  std::filesystem::path cache_dir; // forward (and, unless estimator.cache_dir, inverse) tables; empty: default
  session::RegistrationOptions registration;
  // The relit comparison's reconstruction (compare_with_photographs), its
  // table on `grid` in cache_dir.
  RelitModel relit_model = RelitModel::kTable;
  // The report's files (write_estimate_report): 0 = all cores, 1 = one after another on one thread.
  int writer_threads = 0;
  // A session's cameras estimated at once (estimate_session_cameras), each on
  // a thread of its own beside its estimate's threads: 0 = all, 1 = one
  // after another. The maps are the same either way.
  int cameras_at_once = 0;
  // The subject's width one frame row spans, mm (0: unknown; the session's
  // provenance camera_field_width_mm): the maps' pixel size is this over the
  // maps' width, summary.json's "map_pixel_mm", and the previews' scale bar.
  double field_width_mm = 0;
};

struct MethodEstimationResult {
  std::string summary_json;
  estimation::EstimateSummary summary;
  // The inverter that ran (Inverter::name(): "subspace" where the fast
  // method's plan has more than four channels), summary.json's method.
  std::string inverter;
  double pixels_per_second = 0;
  double map_pixel_mm = 0;  // one map pixel's width on the subject (0: unknown; options.field_width_mm / maps width)
  std::vector<RelitComparison> relit;
  std::vector<session::RegistrationReport> registration;
  std::uint64_t table_key = 0;  // the forward table's cache key (summary.json's table.key)
  // How highlights were found (summary.json's highlights): "optical" (a
  // parallel − cross pair; highlight_pixels = the optical flag's count) or
  // "heuristic" (no parallel capture; highlight_pixels = the specular flag's).
  std::string highlight_detection;
  std::uint64_t highlight_pixels = 0;
  // Wall seconds per stage, in order: summary.json's timings_s
  // (measurement_and_registration, table, inverter_setup, estimate,
  // neighbourhood, relit_comparison, total_before_writing) and "writing"
  // (the report's files), which summary.json cannot hold.
  std::vector<std::pair<std::string, double>> timings_s;
  double seconds(const std::string& stage) const;  // 0 when absent
  // maps.exr's channels as written (its report's order), for the common
  // view of several cameras; estimate_session_cameras releases them after it.
  std::shared_ptr<const files::FloatImage> maps;
};

// The forward table and the inverter of one measurement set, made before the
// subject is captured (the on-line estimator, from the dark and white
// references) and kept in memory until the estimate: estimate_captures()
// uses them instead of reloading both tables from the disk cache when the
// captures' set is the same (same_measurement_set). prepare_tables() fills
// the disk cache as load_or_build() does, so `chromo estimate SESSION_DIR`
// later loads tables with the same numbers.
//
// Thread rules: immutable once made; estimate() may run on any thread.
struct PreparedTables {
  estimation::MeasurementSet set;
  std::shared_ptr<const estimation::ForwardTable> table;
  std::shared_ptr<const estimation::Estimator> estimator;
  // The relit comparison's table of the photographs' illuminants (kTable;
  // null when prepare_tables was given none).
  std::shared_ptr<const RelitTable> relit;
  bool table_rebuilt = false;  // the forward table was not in the disk cache
  double table_seconds = 0;     // loading or building the forward table (and the relit table)
  double inverter_seconds = 0;  // setting up the inverter (the fast one loads or builds its inverse table)
};
// earlier: tables prepared for other cameras of the session; one whose
// forward table has this set's cache key (the same sensitivity and
// illuminants) lends it, shared in memory instead of loaded again; likewise
// its relit table. photograph_illuminants (session::photograph_illuminants of
// the captures; empty: none): the relit comparison's table is made too
// (options.relit_model kTable).
PreparedTables prepare_tables(const estimation::MeasurementSet& set, const MethodEstimationOptions& options,
                              std::span<const PreparedTables* const> earlier = {},
                              std::span<const spectral::Spectrum> photograph_illuminants = {});

// Every number the tables depend on is equal (camera, channels, illuminants, noise).
bool same_measurement_set(const estimation::MeasurementSet& a, const estimation::MeasurementSet& b);

// extra: members added to summary.json (a JSON object; null: none; anything
// else throws std::invalid_argument) (e.g. the session id and source).
// prepared (optional): tables made earlier for the captures' measurement set;
// used when same_measurement_set, otherwise the tables are loaded or built as
// without them. summary.json's timings_s then shows "table" and
// "inverter_setup" as 0 and "tables_in_memory": true in its "table" object.
// Throws std::invalid_argument / session::RegistrationError for unusable captures
// (nothing written), std::runtime_error for failed writes.
MethodEstimationResult estimate_captures(const session::Captures& captures, const MethodEstimationOptions& options,
                                         const std::filesystem::path& out_dir, const FileCommit& commit,
                                         const files::Progress& progress = {}, const nlohmann::ordered_json& extra = {},
                                         const PreparedTables* prepared = nullptr);

// What estimate_captures does once the measurement is made (a measurement
// built elsewhere: the benches' rendered sessions); its timings_s start
// with measurement_seconds.
MethodEstimationResult estimate_measurement(const session::Measurement& measurement,
                                            const spectral::CameraSensitivity& camera, double white_reflectance,
                                            double measurement_seconds, const MethodEstimationOptions& options,
                                            const std::filesystem::path& out_dir, const FileCommit& commit,
                                            const files::Progress& progress = {}, const nlohmann::ordered_json& extra = {},
                                            const PreparedTables* prepared = nullptr);

}  // namespace chromo::maps
