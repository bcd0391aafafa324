#include "chromo/daemon/online_estimator.hpp"

#include <chrono>

#include "chromo/calibration/led_library_io.hpp"
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
                                                       std::function<std::string()> daemon_led_library) {
  OnlineEstimatorOptions options;
  auto& e = options.estimation.estimator;
  // The configuration's loader has checked both names (config.cpp).
  e.method = estimation::parse_method_name(config.method).value_or(estimation::InverterMethod::kFast);
  e.model = estimation::parse_model_name(config.model).value_or(estimation::ModelChoice::kAuto);
  e.threads = config.threads;
  options.estimation.cache_dir = config.cache_dir;
  options.sources = [config, daemon_led_library] {
    std::string library = config.led_library;
    if (library.empty() && daemon_led_library) library = daemon_led_library();
    return session::resolve_capture_sources(library, config.camera_sensitivity, config.white_reflectance);
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
  table_prepared_ = false;
  table_prepare_seconds_ = 0;
  prepared_.reset();
  result_.reset();
  read_back_ = 0;
  wanted_camera_ = session::first_camera_only();
  try {
    sources_ = options_.sources();
    builder_ = std::make_unique<session::SessionCaptureBuilder>(start.plan, *sources_);
  } catch (const std::exception& e) {
    error_ = e.what();
  }
}

void OnlineEstimator::consume(const CapturedFrame& captured, const StoredFrame& stored) {
  if (!builder_ || !error_.empty() || result_) return;
  // One camera's maps: the first camera's frames (the builder keeps cameras apart).
  if (!wanted_camera_(captured.record)) return;
  try {
    builder_->add_frame(captured.record, captured.samples);
    consumed_.insert(stored.index);
    if (!table_prepared_ && builder_->references_complete()) {
      // The subject is not captured yet: build (or load) the table now.
      const auto t = std::chrono::steady_clock::now();
      // Kept in memory until the estimate (it uses them when the subject's
      // frames leave the measurement set unchanged, as they do when the
      // controller applied the same levels), and left in the disk cache for
      // `chromo estimate SESSION_DIR`.
      prepared_ = maps::prepare_tables(builder_->is_method_plan()
                                           ? session::method_set_from_references(builder_->captures())
                                           : session::plan_set_from_references(builder_->plan_captures()),
                                       options_.estimation);
      table_prepared_ = true;
      table_prepare_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    }
    if (builder_->complete()) estimate_now();
  } catch (const std::exception& e) {
    error_ = e.what();
  }
}

void OnlineEstimator::estimate_now() {
  nlohmann::ordered_json extra{{"session_id", session_.id},
                               {"source", "chromod on-line estimator"},
                               {"camera", builder_->camera()},
                               {"led_library", sources_->led_library_source},
                               {"camera_sensitivity", sources_->camera_source},
                               {"white_reflectance", sources_->white_reflectance},
                               {"frames_read_back_from_storage", read_back_},
                               {"table_prepared_during_capture_s", table_prepare_seconds_},
                               {"blue_light_hazard", session::recorded_blue_light_hazard(session_.folder / "journal.jsonl")}};
  const std::filesystem::path results = session_.folder / "results";
  std::filesystem::create_directories(results);
  // The LED library the illuminants came from, so that `chromo estimate
  // SESSION_DIR` reproduces these maps from the folder alone.
  files::write_file_durably(results / "led_library.json", calibration::led_library_to_json(sources_->led_library),
                     options_.budget);
  const maps::FileCommit commit = [this](const std::filesystem::path& path,
                                         const std::function<void(const std::filesystem::path&)>& produce) {
    files::commit_file_durably(path, options_.budget, produce);
  };
  // The method's session, or any other plan (multispectral, an operator's).
  if (builder_->is_method_plan())
    result_ = maps::estimate_method_captures(builder_->captures(), options_.estimation, results, commit, session_.progress,
                                             extra.dump(), prepared_ ? &*prepared_ : nullptr);
  else
    result_ = maps::estimate_plan_captures(builder_->plan_captures(), options_.estimation, results, commit,
                                           session_.progress, extra.dump(), prepared_ ? &*prepared_ : nullptr);
  prepared_.reset();  // the tables' memory goes back before the next session
}

nlohmann::json OnlineEstimator::unavailable(const std::string& reason) const {
  return {{"type", "results"}, {"state", "unavailable"}, {"reason", reason}};
}

nlohmann::json OnlineEstimator::end_session(const SessionEnd& end) {
  if (!end.succeeded) return nullptr;
  if (!builder_ && error_.empty()) return nullptr;
  if (error_.empty() && !result_) {
    // Catch up: the frames the pipeline skipped are in storage.
    try {
      read_back_ = session::add_stored_frames(*builder_, session_.folder, consumed_, wanted_camera_);
      if (!builder_->complete()) {
        error_ = "frames missing: " + builder_->missing();
      } else {
        estimate_now();
      }
    } catch (const std::exception& e) {
      error_ = e.what();
    }
  }
  if (!error_.empty()) return unavailable(error_);
  const auto& r = *result_;
  nlohmann::json flags = nlohmann::json::object();
  for (int f = 0; f < estimation::kPixelFlagCount; ++f)
    flags[std::string(estimation::pixel_flag_name(static_cast<estimation::PixelFlag>(f)))] = r.summary.flag_counts[f];
  nlohmann::json relit = nlohmann::json::object();
  for (const auto& c : r.relit)
    relit[c.illuminant] = {{"mean", c.delta_e94.mean},
                           {"median", c.delta_e94.median},
                           {"p95", c.delta_e94.p95},
                           {"max", c.delta_e94.max},
                           {"pixels", c.delta_e94.pixels}};
  return {{"type", "results"},
          {"state", "available"},
          {"maps_file", "results/maps.exr"},
          {"report_file", "results/summary.json"},
          {"method", std::string(estimation::method_name(options_.estimation.estimator.method))},
          {"model", std::string(estimation::model_name(options_.estimation.estimator.model))},
          {"pixels", r.summary.pixels},
          {"pixels_per_second", r.pixels_per_second},
          {"estimate_seconds", r.summary.seconds},
          {"frames_read_back", read_back_},
          {"flag_counts", flags},
          {"relit_delta_e94", relit}};
}

}  // namespace chromo::daemon
