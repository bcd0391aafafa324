// chromo estimate: offline chromophore estimation from a measurement
// description (docs/formats/measurement.md) or a stored session folder
// (docs/formats/session.md) to parameter maps, previews and a summary
// (maps/estimate_report.hpp). Everything is read and checked before
// anything is written; outputs are written under temporary names and renamed
// into place at the end (OutputBatch). A session folder goes through the
// daemon's own SessionCaptureBuilder and estimate_captures(), so the
// maps equal the on-line estimator's for the same frames and LED library.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>

#include "chromo/maps/camera_results.hpp"
#include "chromo/maps/estimate_report.hpp"
#include "chromo/session/plan_hazard.hpp"
#include "chromo/session/session_captures.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/session/measurement_file.hpp"
#include "chromo/files/output_batch.hpp"
#include "chromo/estimation/spatial_flags.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "commands.hpp"
#include "session_estimate.hpp"
#include "chromo/files/float_image.hpp"

namespace chromo::cli {
namespace {

namespace fs = std::filesystem;

// Stages a report's files in an OutputBatch (renamed into place by commit()).
maps::FileCommit stage_in(files::OutputBatch& batch) {
  return [&batch](const fs::path& path, const std::function<void(const fs::path&)>& produce) {
    produce(batch.temporary(path.filename().string()));
  };
}

// Prints one camera's figures (prefix: "camera NAME: " with several cameras).
void print_camera_result(const maps::MethodEstimationResult& result, const EstimateOptions& options,
                         const std::string& prefix) {
  fmt::print("{}{} pixels, method {} model {}: {:.3f} s ({:.0f} pixels/s); {} explained, {} flagged\n", prefix,
             result.summary.pixels, result.inverter, options.model, result.summary.seconds, result.pixels_per_second,
             result.summary.flag_counts[0], result.summary.pixels - result.summary.flag_counts[0]);
  for (const auto& r : result.relit)
    fmt::print("{}relit ΔE94 against the photograph under {}: mean {:.3f}, median {:.3f}, p95 {:.3f}\n", prefix,
               r.illuminant, r.delta_e94.mean, r.delta_e94.median, r.delta_e94.p95);
}

// A stored session folder: the same captures and estimation as chromod's
// on-line estimator, every camera (session_estimate.hpp).
int run_estimate_session(const EstimateOptions& options) {
  const SessionEstimate outcome = estimate_stored_session(options);
  for (const std::string& line : outcome.errors) std::cerr << "chromo estimate: " << line << "\n";
  if (outcome.exit_status != kExitOk) return outcome.exit_status;
  for (const auto& camera : outcome.cameras)
    if (camera.ok)
      print_camera_result(*camera.result, options, outcome.cameras.size() > 1 ? "camera " + camera.camera + ": " : "");
  return kExitOk;
}

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// A MEASUREMENT.json read, its images registered and its measurement set checked.
struct LoadedMeasurement {
  session::MeasurementFile m;
  nlohmann::ordered_json registration;
  estimation::MeasurementSet set;
  double load_seconds = 0, registration_seconds = 0;
};

// Reads options.input into `loaded`: kExitOk, or kExitBadInput said on
// stderr (the file, a registration, the set).
int load_measurement(const EstimateOptions& options, LoadedMeasurement& loaded) {
  const auto start = std::chrono::steady_clock::now();
  session::MeasurementFile& m = loaded.m;
  try {
    m = session::read_measurement_file(options.input);
  } catch (const session::MeasurementFileError& e) {
    std::cerr << "chromo estimate: " << e.what() << "\n";
    return kExitBadInput;
  }
  loaded.load_seconds = seconds_since(start);

  // Register every further image to images[0] on the first channel both use.
  const auto t = std::chrono::steady_clock::now();
  try {
    loaded.registration = maps::registration_report(session::register_images(m));
  } catch (const session::RegistrationError& e) {
    std::cerr << "chromo estimate: " << e.what() << "\n";
    return kExitBadInput;
  }
  loaded.registration_seconds = seconds_since(t);

  // Measurement set and the pixel-major measurement vector.
  loaded.set = m.measurement_set();
  try {
    loaded.set.validate();
  } catch (const std::invalid_argument& e) {
    std::cerr << "chromo estimate: measurement set: " << e.what() << "\n";
    return kExitBadInput;
  }
  return kExitOk;
}

int run_estimate(const EstimateOptions& options) {
  // Not throwing: a path that cannot be looked at (a loop of links) is a
  // file the bounded reader then refuses, naming it (exit 2).
  std::error_code unreadable;
  if (fs::is_directory(options.input, unreadable)) return run_estimate_session(options);
  LoadedMeasurement loaded;
  if (const int status = load_measurement(options, loaded); status != kExitOk) return status;
  const session::MeasurementFile& m = loaded.m;
  const estimation::MeasurementSet& set = loaded.set;
  const std::size_t pixels = static_cast<std::size_t>(m.width) * m.height;
  const int channels = set.size();
  const std::vector<float> measured = m.pixel_major();

  auto t = std::chrono::steady_clock::now();
  bool rebuilt = false;
  std::shared_ptr<const estimation::ForwardTable> table;
  try {
    table = estimation::ForwardTable::load_or_build(
        set, {}, options.cache_dir.empty() ? estimation::ForwardTable::default_cache_dir() : fs::path(options.cache_dir),
        &rebuilt, options.threads);
  } catch (const std::exception& e) {
    std::cerr << "chromo estimate: building the table: " << e.what() << "\n";
    return kExitFailure;
  }
  const double table_seconds = seconds_since(t);

  estimation::EstimatorOptions eo = estimator_options(options);
  // The pooled order replaces every explained pixel's: the per-pixel rule is then the cheap one (estimator.hpp).
  if (options.order_pooling) eo.order_rule = estimation::EstimatorOptions::OrderRule::kLikelihoodRatio;
  t = std::chrono::steady_clock::now();
  const estimation::Estimator estimator(table, set, eo);
  const double inverter_setup_seconds = seconds_since(t);
  std::vector<estimation::PixelEstimate> out(pixels);
  // The auto model's other-order fits, for the pooled order (same maps, no refits).
  std::vector<estimation::OtherOrderFit> other(
      options.order_pooling && estimator.options().model == estimation::ModelChoice::kAuto ? pixels : 0);
  estimation::EstimateSummary summary = estimator.estimate(measured, out, {}, {}, other);
  // The spatial pass, with the multi-pixel estimate when --skin-denoise on.
  const std::optional<estimation::SkinDenoiseOptions> skin_denoise = skin_denoise_options(options);
  estimation::NeighbourhoodOptions no;
  no.flags = options.neighbourhood_flags;
  no.pool_order = options.order_pooling;
  no.local_bias.enabled = options.local_bias == "on";
  const estimation::SpatialPass pass =
      estimation::spatial_pass(estimator, measured, m.width, m.height, out, summary, no, skin_denoise, other);
  const estimation::NeighbourhoodSummary& neighbourhood = pass.neighbourhood;
  // The relit layer "model + discrepancy" (--discrepancy-layer; maps/discrepancy_layer.hpp).
  const std::optional<maps::DiscrepancyLayer> layer = maps::estimate_discrepancy_layer(
      estimator, measured, out, pass.skin_refit ? &*pass.skin_refit : nullptr, discrepancy_layer_terms(options));
  const double neighbourhood_seconds = pass.neighbourhood_seconds;

  maps::EstimateReport report;
  report.method = std::string(estimator.inverter().name());  // the inverter that ran
  report.model = options.model;
  report.width = m.width, report.height = m.height;
  for (const auto& c : set.channels) report.channel_names.push_back(c.name);
  report.estimates = out;
  report.summary = summary;
  report.discrepancy_layer = layer ? &*layer : nullptr;
  report.timings_s = {{"load", loaded.load_seconds},
                      {"registration", loaded.registration_seconds},
                      {"table", table_seconds},
                      {"inverter_setup", inverter_setup_seconds},
                      {"neighbourhood", neighbourhood_seconds}};
  nlohmann::ordered_json extra{{"input", options.input},
                               {"table", {{"key", fmt::format("{:016x}", table->key())},
                                          {"nodes", table->grid().node_count()},
                                          {"rebuilt", rebuilt}}},
                               {"registration", loaded.registration},
                               {"neighbourhood", maps::neighbourhood_report(options.neighbourhood_flags,
                                                                            options.order_pooling, neighbourhood)},
                               {"skin_denoise", maps::skin_denoise_report(skin_denoise, pass.skin_refit ? &*pass.skin_refit : nullptr)},
                               {"discrepancy_layer", maps::discrepancy_layer_report(report.discrepancy_layer)}};
  report.extra = std::move(extra);
  try {
    files::OutputBatch files(options.out);
    maps::write_estimate_report(options.out, report, stage_in(files));
    files.commit();
  } catch (const std::exception& e) {
    std::cerr << "chromo estimate: writing " << options.out << ": " << e.what() << "\n";
    return kExitFailure;
  }
  fmt::print("{}×{} pixels, {} channels, method {} model {}: {:.3f} s ({:.0f} pixels/s); {} explained, {} flagged\n",
             m.width, m.height, channels, report.method, options.model, summary.seconds,
             summary.seconds > 0 ? pixels / summary.seconds : 0.0, summary.flag_counts[0],
             pixels - summary.flag_counts[0]);
  return kExitOk;
}

}  // namespace

void add_estimate_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<EstimateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "estimate", "Estimate chromophore maps from a measurement (MEASUREMENT.json) or a stored session folder");
  cmd->add_option("measurement", options->input,
                  "MEASUREMENT.json (docs/formats/measurement.md) or SESSION_DIR (docs/formats/session.md)")
      ->required();
  cmd->add_option("--out", options->out, "output directory (maps.exr, previews, summary.json)")->required();
  cmd->add_option("--method", options->method, "inverter")
      ->check(CLI::IsMember({"exhaustive", "fast", "2d", "subspace"}))
      ->capture_default_str();
  cmd->add_option("--model", options->model, "model order: auto (χ² likelihood-ratio test, pooled over 7×7 windows unless --no-order-pooling), 2d or 4d")
      ->check(CLI::IsMember({"auto", "2d", "4d"}))
      ->capture_default_str();
  cmd->add_option("--discrepancy", options->discrepancy,
                  "the skin model's shortfall on real skin, added to the noise wherever a residual is weighed: learned "
                  "(from the NIST forearm spectra, docs/estimation.md 'Real skin') or none (camera noise alone)")
      ->check(CLI::IsMember({"learned", "none"}))
      ->capture_default_str();
  cmd->add_option("--prior", options->prior,
                  "real-skin: where a plan has at most four channels (the method's), take the most probable parameters "
                  "of real skin among those that explain a pixel (a prior learned from the NIST forearms' fits; lowers "
                  "the relit error on real skin, raises it on skin unlike the forearms: docs/estimation.md 'A prior "
                  "learned from real skin'); none (default): the data alone")
      ->check(CLI::IsMember({"none", "real-skin"}))
      ->capture_default_str();
  cmd->add_flag("--neighbourhood-flags,!--no-neighbourhood-flags", options->neighbourhood_flags,
                "flag pixels from their neighbourhood (code 7: weak rims of flagged regions, part of a highlight; "
                "the deviation is measured against the noise plus the skin's own local scatter, see "
                "docs/estimation.md); on by default, --no-neighbourhood-flags for per-pixel flags only");
  cmd->add_flag("!--no-order-pooling", options->order_pooling,
                "with --model auto, decide the order per pixel only (default: the likelihood-ratio statistic pooled "
                "over 7×7 windows)");
  cmd->add_option("--skin-denoise", options->skin_denoise,
                  "on: the multi-pixel estimate before the spatial pass (each explained pixel's colour averaged with "
                  "its 11×11 neighbours' that agree within the noise, its brightness kept, then fitted again; flags "
                  "unchanged: docs/estimation.md 'Relighting past the model'; the default); off: per pixel only")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  cmd->add_option("--local-bias", options->local_bias,
                  "on: before the neighbourhood flags, a pixel flagged 5/6 is judged against the median residual of "
                  "the explained skin around it (40 px), capped at one flag threshold, so a subject outside the "
                  "model's learned range is not flagged whole (docs/estimation.md 'A subject's shortfall as a local "
                  "bias'); off (default): per-pixel flags as they are")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  cmd->add_option("--discrepancy-layer", options->discrepancy_layer,
                  "on: store each explained pixel's posterior discrepancy (the learned discrepancy's estimate of what "
                  "the model missed, from the pixel's residual) in the maps, so every relighting adds it (nothing where "
                  "the fit left no residual; needs --discrepancy learned: docs/estimation.md 'Relighting past the "
                  "model'); off: the maps relight with the model alone")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  cmd->add_option("--cache-dir", options->cache_dir, "table cache (default $CHROMO_CACHE_DIR or ~/.cache/chromosphere)");
  cmd->add_option("--threads", options->threads, "threads (0 = all cores)")->capture_default_str();
  cmd->add_option("--led-library", options->led_library,
                  "SESSION_DIR only: LED library (default: the session's results/led_library.json, else as chromod)");
  cmd->add_option("--camera", options->camera, "SESSION_DIR only: camera sensitivity, builtin:NAME or a CSV")
      ->capture_default_str();
  cmd->add_option("--camera-of", options->camera_of,
                  "SESSION_DIR only: one camera's sensitivity, NAME=builtin:NAME or NAME=CSV (repeatable; others use --camera)");
  cmd->add_option("--white-reflectance", options->white_reflectance, "SESSION_DIR only: ρ of the white target")
      ->capture_default_str();
  cmd->callback([options, &exit_status] { exit_status = run_estimate(*options); });
}

}  // namespace chromo::cli
