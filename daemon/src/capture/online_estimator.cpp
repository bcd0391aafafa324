#include "chromo/daemon/internal/capture/online_estimator.hpp"

#include "chromo/estimation/model_discrepancy.hpp"

#include <chrono>

#include "chromo/calibration/led_library_io.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/session/plan_hazard.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::daemon {

bool OnlineEstimatorOptions::IsValid(std::string* error) const {
  if (!sources) {
    if (error) *error = "sources: no LED library / camera resolver";
    return false;
  }
  return estimation.estimator.IsValid(error) && estimation.grid.IsValid(error);
}

std::unique_ptr<OnlineEstimator> make_online_estimator(const EstimationConfig& config, files::StorageBudget* budget,
                                                       std::function<std::string()> daemon_led_library,
                                                       std::function<std::map<drivers::Polarisation, session::StateLedLibrary>()>
                                                           daemon_state_libraries,
                                                       std::optional<session::SurfaceFactors> devices_films) {
  OnlineEstimatorOptions options;
  auto& e = options.estimation.estimator;
  // The configuration's loader has checked both names (config.cpp).
  e.method = estimation::parse_method_name(config.method).value_or(estimation::InverterMethod::kFast);
  e.model = estimation::parse_model_name(config.model).value_or(estimation::ModelChoice::kAuto);
  e.threads = config.threads;
  e.discrepancy = config.discrepancy == "none" ? nullptr : estimation::ModelDiscrepancy::standard();
  // The multi-pixel estimate (estimation.skin_denoise, checked on or off by config.cpp).
  if (config.skin_denoise == "on") options.estimation.skin_denoise = estimation::SkinDenoiseOptions{};
  // The registration's tile consensus (estimation.registration_tiles, checked on or off by config.cpp).
  options.estimation.registration.tile_consensus = config.registration_tiles == "on";
  // The local-bias flag rule (estimation.local_bias, checked on or off by config.cpp).
  options.estimation.neighbourhood.local_bias.enabled = config.local_bias == "on";
  // The relit layer (estimation.discrepancy_layer, checked on or off by config.cpp).
  options.estimation.discrepancy_layer_terms = config.discrepancy_layer == "on" ? maps::kDiscrepancyLayerTerms : 0;
  options.estimation.cache_dir = config.cache_dir;
  options.sources = [config, daemon_led_library, daemon_state_libraries, devices_films] {
    std::string library = config.led_library;
    if (library.empty() && daemon_led_library) library = daemon_led_library();
    // The daemon's own library or the nominal one: never the user's newest (another daemon's).
    if (library.empty()) library = session::kNominalLedLibrary;
    auto sources = session::resolve_capture_sources(library, config.camera_sensitivity, config.white_reflectance,
                                                    config.camera_sensitivities);
    if (config.led_library.empty() && daemon_state_libraries) sources.led_library_of_state = daemon_state_libraries();
    if (config.films_extinction_ratio == kVirtualLabFilms) {
      if (!devices_films)
        throw std::runtime_error("estimation.films_extinction_ratio \"virtual_lab\": the devices are not the virtual lab");
      sources.surface_factors = *devices_films;
    } else if (!config.films_extinction_ratio.empty())
      sources.surface_factors = session::surface_factors_of_extinction_file(config.films_extinction_ratio);
    return sources;
  };
  options.budget = budget;
  return std::make_unique<OnlineEstimator>(std::move(options));
}

OnlineEstimator::OnlineEstimator(OnlineEstimatorOptions options) : options_(std::move(options)) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("on-line estimator: " + error);
}

void OnlineEstimator::begin_session(const SessionStart& start) {
  session_ = start;
  builder_.reset();
  consumed_.clear();
  error_.clear();
  camera_errors_.clear();
  table_prepare_seconds_.clear();
  preparations_.wait_all();  // an earlier session's, if it ended before its estimate
  prepared_.clear();
  cameras_.clear();
  estimated_ = false;
  read_back_ = 0;
  try {
    sources_ = options_.sources();
    builder_ = std::make_unique<session::SessionCaptureBuilder>(start.plan, *sources_, start.stored_sums);
  } catch (const std::exception& e) {
    error_ = e.what();
  }
}

bool OnlineEstimator::every_camera_complete() const {
  const auto& delivered = builder_->cameras();
  // Without the session's camera list, the end of the session says when.
  if (session_.cameras.empty() || delivered.size() < session_.cameras.size()) return false;
  for (const auto& camera : delivered)
    if (!builder_->complete(camera)) return false;
  return true;
}

void OnlineEstimator::prepare_tables_of(const std::string& camera) {
  // The subject is not captured yet: build (or load) the tables now, on a
  // thread of the camera's own (TablePreparations), while this thread takes
  // the subject's frames. Kept in memory until the estimate (it uses them
  // when the subject's frames leave the measurement set unchanged, as they
  // do when the controller applied the same levels), and left in the disk
  // cache for `chromo estimate SESSION_DIR`. A camera with another camera's
  // sensitivity and illuminants shares that camera's forward table.
  auto captures = std::make_shared<const session::Captures>(builder_->captures(camera));
  auto set = std::make_shared<std::optional<estimation::MeasurementSet>>();
  const maps::MethodEstimationOptions options = options_.estimation;
  preparations_.start(camera, {[captures, set, grid = options.grid] {
                                 *set = session::measurement_set_from_references(*captures);
                                 return estimation::ForwardTable::cache_key(**set, grid);
                               },
                               [captures, set, options](std::span<const maps::PreparedTables* const> earlier) {
                                 // The relit comparison's table too: the photographs' illuminants are the whites'.
                                 return maps::prepare_tables(**set, options, earlier,
                                                             session::photograph_illuminants(*captures));
                               }});
}

void OnlineEstimator::consume(const CapturedFrame& captured, const StoredFrame& stored) {
  if (!builder_ || !error_.empty() || estimated_) return;
  const std::string& camera = captured.record.camera;
  try {
    // The storage thread has summed the frame's samples when it is given one to sum into.
    if (builder_->reads_stored_sums()) builder_->add_summed_frame(captured.record);
    else builder_->add_frame(captured.record, captured.samples);
    consumed_.insert(stored.index);
  } catch (const std::exception& e) {
    // One camera's unusable frame fails the session's estimate only when it is the one camera.
    if (session_.cameras.size() <= 1) error_ = e.what();
    else camera_errors_.emplace(camera, e.what());
    return;
  }
  try {
    if (!preparations_.started(camera) && builder_->references_complete(camera)) prepare_tables_of(camera);
  } catch (const std::exception&) {
    // The estimate names what is wrong with this camera's references.
  }
  try {
    if (every_camera_complete()) estimate_now();
  } catch (const std::exception& e) {
    error_ = e.what();
  }
}

void OnlineEstimator::estimate_now() {
  estimated_ = true;
  // The tables being prepared since each camera's references (usually ready by now).
  TablePreparations::Ready ready = preparations_.wait_all();
  prepared_ = std::move(ready.tables);
  table_prepare_seconds_ = std::move(ready.seconds);
  nlohmann::ordered_json prepare_seconds = nlohmann::ordered_json::object();
  for (const auto& [camera, seconds] : table_prepare_seconds_) prepare_seconds[camera] = seconds;
  nlohmann::ordered_json extra{{"session_id", session_.id},
                               {"source", "chromod on-line estimator"},
                               {"led_library", sources_->led_library_source},
                               {"led_library_of_state", session::state_library_sources(*sources_)},
                               {"white_reflectance", sources_->white_reflectance},
                               {"frames_read_back_from_storage", read_back_},
                               {"table_prepared_during_capture_s",
                                table_prepare_seconds_.size() == 1 ? nlohmann::ordered_json(table_prepare_seconds_.begin()->second)
                                                                   : prepare_seconds},
                               {"blue_light_hazard", session_.blue_light_hazard ? session_.blue_light_hazard->latest()
                                                                                : nlohmann::ordered_json()}};
  if (session_.provenance.recorded) extra["provenance"] = session::to_json(session_.provenance);
  const std::filesystem::path results = session_.folder / "results";
  std::filesystem::create_directories(results);
  // The LED library the illuminants came from, so that `chromo estimate
  // SESSION_DIR` reproduces these maps from the folder alone.
  files::write_file_durably(results / "led_library.json", calibration::led_library_to_json(sources_->led_library),
                            options_.budget);
  for (const auto& [state, measured] : sources_->led_library_of_state)
    files::write_file_durably(results / session::session_state_library_file(state),
                              calibration::led_library_to_json(measured.library), options_.budget);
  const maps::FileCommit commit = [this](const std::filesystem::path& path,
                                         const std::function<void(const std::filesystem::path&)>& produce) {
    std::filesystem::create_directories(path.parent_path());
    files::commit_file_durably(path, options_.budget, produce);
  };
  // The method's session, or any other plan (multispectral, an operator's), every camera.
  cameras_ = maps::estimate_session_cameras({builder_.get(), &prepared_, extra, camera_errors_,
                                             session_.provenance.camera_field_width_mm},
                                            options_.estimation, results, commit, session_.progress);
  prepared_.clear();  // the tables' memory goes back before the next session
}

nlohmann::json OnlineEstimator::unavailable(const std::string& reason) const {
  return {{"type", "results"}, {"state", "unavailable"}, {"reason", reason}};
}

nlohmann::json OnlineEstimator::end_session(const SessionEnd& end) {
  nlohmann::json record = results_record(end);
  builder_.reset();  // the captures' sums (the stored ones too) go back before the next session
  return record;
}

nlohmann::json OnlineEstimator::results_record(const SessionEnd& end) {
  if (!end.succeeded) return nullptr;
  if (!builder_ && error_.empty()) return nullptr;
  if (error_.empty() && !estimated_) {
    // Catch up: the frames the pipeline skipped are in storage.
    try {
      read_back_ = session::add_stored_frames(*builder_, session_.folder, consumed_, {},
                                              session_.cameras.size() <= 1 ? nullptr : &camera_errors_);
      if (builder_->cameras().size() <= 1 && camera_errors_.empty() && !builder_->complete()) {
        error_ = "frames missing: " + builder_->missing();
      } else {
        estimate_now();
      }
    } catch (const std::exception& e) {
      error_ = e.what();
    }
  }
  if (!error_.empty()) return unavailable(error_);
  const maps::CameraEstimate* first_ok = nullptr;
  nlohmann::json cameras = nlohmann::json::array();
  std::string reasons;
  for (const auto& camera : cameras_) {
    cameras.push_back(nlohmann::json(maps::camera_entry(camera, "results/")));
    if (camera.ok && !first_ok) first_ok = &camera;
    if (!camera.ok) reasons += (reasons.empty() ? "" : "; ") + camera.camera + ": " + camera.reason;
  }
  if (!first_ok) {
    nlohmann::json record = unavailable(reasons);
    record["cameras"] = cameras;
    return record;
  }
  const auto& r = *first_ok->result;
  // Its flag counts and relit ΔE94 as its index entry has them.
  const nlohmann::json first_entry = maps::camera_entry(*first_ok);
  // The headline numbers are the first estimated camera's; "cameras" lists every camera.
  const std::string first_folder = first_ok->folder.empty() ? "results/" : "results/" + first_ok->folder + "/";
  return {{"type", "results"},
          {"state", "available"},
          {"maps_file", first_folder + "maps.exr"},
          {"report_file", "results/summary.json"},
          {"camera", first_ok->camera},
          {"method", r.inverter},
          {"model", std::string(estimation::model_name(options_.estimation.estimator.model))},
          {"pixels", r.summary.pixels},
          {"pixels_per_second", r.pixels_per_second},
          {"estimate_seconds", r.summary.seconds},
          {"frames_read_back", read_back_},
          {"flag_counts", first_entry["flag_counts"]},
          {"relit_delta_e94", first_entry["relit_delta_e94"]},
          {"highlights", first_entry["highlights"]},
          {"cameras", cameras}};
}

}  // namespace chromo::daemon
