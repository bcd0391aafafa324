#pragma once
// The estimation of one stored session folder, as `chromo estimate
// SESSION_DIR --out DIR` runs it: the session's frames through the daemon's
// own SessionCaptureBuilder and maps::estimate_session_cameras(), every
// camera, written through OutputBatch (temporary names, renamed into place at
// the end; a failed run leaves nothing). `chromo study` calls the same
// function for each session of a study, so a study's maps equal `chromo
// estimate`'s for the same frames and options.
//
// Thread rules: a free function; the estimation uses options.threads cores.

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/skin_denoise.hpp"
#include "chromo/maps/camera_results.hpp"

namespace chromo::cli {

// `chromo estimate`'s options (both inputs; the session-only ones marked).
struct EstimateOptions {
  std::string input;
  std::string out;
  std::string method = "fast";
  std::string model = "auto";
  std::string discrepancy = "learned";  // the model's learned discrepancy on real skin, or "none"
  std::string prior = "none";           // "real-skin": the parameter prior learned from the NIST forearms (≤ 4 channels)
  std::string cache_dir;
  int threads = 0;
  bool neighbourhood_flags = true;
  bool order_pooling = true;
  std::string skin_denoise = "on";      // "off": no multi-pixel estimate (estimation/skin_refit.hpp) before the spatial pass
  std::string local_bias = "off";       // "on": a skin's systematic shortfall taken as a local bias (estimation/local_bias.hpp)
  std::string discrepancy_layer = "on"; // "off": the maps carry no posterior discrepancy (maps/discrepancy_layer.hpp)
  // Session folders only.
  std::string led_library;  // empty: <session>/results/led_library.json, else as chromod (newest measured, nominal)
  std::string camera = "builtin:nikon_d5100";
  std::vector<std::string> camera_of;  // NAME=SPEC: one camera's sensitivity
  double white_reflectance = 0.99;
};

estimation::EstimatorOptions estimator_options(const EstimateOptions& options);
// --skin-denoise as the maps' option: the multi-pixel estimate's defaults when "on", empty when "off".
std::optional<estimation::SkinDenoiseOptions> skin_denoise_options(const EstimateOptions& options);
// --discrepancy-layer as the maps' option: the layer's terms when "on", 0 when "off".
int discrepancy_layer_terms(const EstimateOptions& options);
// --camera-of's NAME=SPEC entries as a map; std::invalid_argument naming a malformed one.
std::map<std::string, std::string> parse_camera_of(const std::vector<std::string>& entries);

// What one session's estimation gave.
struct SessionEstimate {
  int exit_status = 0;              // commands.hpp: kExitOk, kExitBadInput, kExitFailure
  std::vector<std::string> errors;  // one line each, without the command's prefix
  std::vector<maps::CameraEstimate> cameras;  // every camera, ok or failed (with its reason)
};

// Estimates the session folder options.input into options.out. `source` is
// summary.json's "source" member. Never throws for a bad session (its
// errors are returned); std::bad_alloc and the like propagate.
SessionEstimate estimate_stored_session(const EstimateOptions& options,
                                        const std::string& source = "chromo estimate SESSION_DIR");

}  // namespace chromo::cli
