// The estimation of one stored session folder (session_estimate.hpp): what
// `chromo estimate SESSION_DIR` and `chromo study` run for each session.
#include "session_estimate.hpp"

#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/parameter_prior.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <map>
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>

#include "chromo/files/output_batch.hpp"
#include "chromo/maps/estimate_report.hpp"
#include "chromo/session/plan_hazard.hpp"
#include "chromo/session/session_captures.hpp"
#include "commands.hpp"

namespace chromo::cli {

namespace fs = std::filesystem;

std::map<std::string, std::string> parse_camera_of(const std::vector<std::string>& entries) {
  std::map<std::string, std::string> camera_of;
  for (const std::string& entry : entries) {
    const auto equals = entry.find('=');
    if (equals == std::string::npos || equals == 0 || equals + 1 == entry.size())
      throw std::invalid_argument("--camera-of: \"" + entry + "\" is not NAME=SPEC (builtin:NAME or a CSV)");
    camera_of[entry.substr(0, equals)] = entry.substr(equals + 1);
  }
  return camera_of;
}

estimation::EstimatorOptions estimator_options(const EstimateOptions& options) {
  estimation::EstimatorOptions eo;
  // CLI11 has checked both names against the same lists.
  eo.method = estimation::parse_method_name(options.method).value_or(estimation::InverterMethod::kFast);
  eo.model = estimation::parse_model_name(options.model).value_or(estimation::ModelChoice::kAuto);
  eo.threads = options.threads;
  // The model's learned discrepancy on real skin (docs/estimation.md "Real skin"), or none.
  eo.discrepancy = options.discrepancy == "learned" ? estimation::ModelDiscrepancy::standard() : nullptr;
  // The parameter prior of real skin (docs/estimation.md "A prior learned from real skin"), or none.
  eo.prior = options.prior == "real-skin" ? estimation::ParameterPrior::standard() : nullptr;
  eo.cache_dir = options.cache_dir;  // the fast method's inverse table next to the forward table
  return eo;
}

std::optional<estimation::SkinDenoiseOptions> skin_denoise_options(const EstimateOptions& options) {
  // CLI11 has checked the value against on and off.
  if (options.skin_denoise == "on") return estimation::SkinDenoiseOptions{};
  return std::nullopt;
}

session::RegistrationOptions registration_options(const EstimateOptions& options) {
  // CLI11 has checked the value against on and off.
  session::RegistrationOptions registration;
  registration.tile_consensus = options.registration_tiles == "on";
  return registration;
}

int discrepancy_layer_terms(const EstimateOptions& options) {
  // CLI11 has checked the value against on and off.
  return options.discrepancy_layer == "on" ? maps::kDiscrepancyLayerTerms : 0;
}

SessionEstimate estimate_stored_session(const EstimateOptions& options, const std::string& source) {
  SessionEstimate outcome;
  const fs::path folder = options.input;
  auto fail = [&outcome](int status, std::string line) {
    outcome.exit_status = status;
    outcome.errors.push_back(std::move(line));
    return outcome;
  };
  session::CaptureSources sources;
  std::optional<session::SessionCaptureBuilder> builder;
  std::map<std::string, std::string> unusable;  // cameras whose frames the builder refused
  nlohmann::ordered_json hazard;
  std::map<std::string, double> field_width_mm;  // the maps' scale where the session knows it
  try {
    std::string library = options.led_library;
    if (library.empty() && fs::exists(folder / "results" / "led_library.json"))
      library = (folder / "results" / "led_library.json").string();
    const std::map<std::string, std::string> camera_of = parse_camera_of(options.camera_of);
    sources = session::resolve_capture_sources(library, options.camera, options.white_reflectance, camera_of);
    // The session's own per-state libraries, unless --led-library overrides the illuminants.
    if (options.led_library.empty()) session::load_session_state_libraries(folder / "results", sources);
    builder.emplace(session::read_stored_session(folder, sources, &unusable));
    field_width_mm = session::read_session_provenance(folder).camera_field_width_mm;
    for (const auto& [name, spec] : camera_of)
      if (std::find(builder->cameras().begin(), builder->cameras().end(), name) == builder->cameras().end())
        throw std::invalid_argument("--camera-of: the session has no camera \"" + name + "\" (its cameras: " +
                                    fmt::format("{}", fmt::join(builder->cameras(), ", ")) + ")");
    hazard = session::recorded_blue_light_hazard(folder / "journal.jsonl");
  } catch (const std::exception& e) {
    return fail(kExitBadInput, e.what());
  }
  maps::MethodEstimationOptions eo;
  eo.estimator = estimator_options(options);
  eo.neighbourhood.flags = options.neighbourhood_flags;
  eo.neighbourhood.pool_order = options.order_pooling;
  eo.skin_denoise = skin_denoise_options(options);
  eo.registration = registration_options(options);
  eo.neighbourhood.local_bias.enabled = options.local_bias == "on";
  eo.discrepancy_layer_terms = discrepancy_layer_terms(options);
  if (!options.cache_dir.empty()) eo.cache_dir = options.cache_dir;
  nlohmann::ordered_json extra{{"session", fs::absolute(folder).string()},
                               {"source", source},
                               {"led_library", sources.led_library_source},
                               {"led_library_of_state", session::state_library_sources(sources)},
                               {"white_reflectance", sources.white_reflectance},
                               {"blue_light_hazard", hazard}};
  try {
    // One batch per folder written: OUT, and OUT/<camera> with several
    // cameras; each is removed again (with the directory it made) unless
    // committed. The camera batches go first, so OUT is empty when its batch goes.
    const fs::path out_dir = (fs::path(options.out) / "x").parent_path().lexically_normal();
    files::OutputBatch out_batch(options.out);
    std::map<fs::path, std::unique_ptr<files::OutputBatch>> camera_batches;
    const maps::FileCommit commit = [&](const fs::path& path, const std::function<void(const fs::path&)>& produce) {
      const fs::path dir = path.parent_path().lexically_normal();
      if (dir == out_dir) return produce(out_batch.temporary(path.filename().string()));
      auto& batch = camera_batches[dir];
      if (!batch) batch = std::make_unique<files::OutputBatch>(dir);
      produce(batch->temporary(path.filename().string()));
    };
    try {
      outcome.cameras =
          maps::estimate_session_cameras({&*builder, nullptr, extra, unusable, field_width_mm}, eo, options.out, commit);
    } catch (const std::invalid_argument& e) {
      return fail(kExitBadInput, folder.string() + ": " + e.what());
    } catch (const session::RegistrationError& e) {
      return fail(kExitBadInput, folder.string() + ": " + e.what());
    }
    std::size_t failed = 0;
    for (const auto& camera : outcome.cameras)
      if (!camera.ok) {
        camera_batches.erase((fs::path(options.out) / camera.folder).lexically_normal());
        outcome.errors.push_back(folder.string() + ": camera " + camera.camera + ": " + camera.reason);
        ++failed;
      }
    if (failed == outcome.cameras.size()) {
      outcome.exit_status = kExitBadInput;
      return outcome;
    }
    for (auto& [dir, batch] : camera_batches) batch->commit();
    out_batch.commit();
  } catch (const std::exception& e) {
    return fail(kExitFailure, "writing " + options.out + ": " + e.what());
  }
  return outcome;
}

}  // namespace chromo::cli
