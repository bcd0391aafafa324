#include "chromo/daemon/calibrations.hpp"
#include "chromo/files/bounded_read.hpp"

#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "chromo/calibration/calibration_run.hpp"
#include "chromo/calibration/led_library_io.hpp"
#include "chromo/calibration/mix_solver.hpp"
#include "chromo/calibration/session_mix.hpp"
#include "chromo/files/temporary_file.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/session/session_store.hpp"
#include "chromo/spectral/camera.hpp"

namespace chromo::daemon {

namespace {

constexpr const char* kRecordFile = "calibration.json";
constexpr const char* kLibraryFile = "led-library.json";

// Calls a named device under its mutex (one call at a time).
template <typename Interface>
class LockedCalls {
 protected:
  explicit LockedCalls(NamedDevice<Interface>& d) : d_(d) {}
  template <typename F>
  auto call(F&& f) const -> decltype(f()) {
    std::lock_guard lock(d_.mutex);
    return f();
  }
  Interface& device() const { return *d_.device; }

 private:
  NamedDevice<Interface>& d_;
};

// The devices' own interfaces, each call under the device's mutex: the run
// holds no lock between calls, so status queries are answered meanwhile.
class LockedLeds final : public drivers::LedController, LockedCalls<drivers::LedController> {
 public:
  explicit LockedLeds(NamedDevice<drivers::LedController>& d) : LockedCalls(d) {}
  drivers::LedControllerInfo info() const override { return call([&] { return device().info(); }); }
  void set_state(const drivers::LedState& state) override { call([&] { device().set_state(state); }); }
  drivers::LedStatus read_status() override { return call([&] { return device().read_status(); }); }
  void set_output_enabled(bool enabled) override { call([&] { device().set_output_enabled(enabled); }); }
  void arm_sequence(std::span<const drivers::LedState> states, drivers::SequenceTrigger trigger) override {
    call([&] { device().arm_sequence(states, trigger); });
  }
  void advance_sequence() override { call([&] { device().advance_sequence(); }); }
  void disarm_sequence() override { call([&] { device().disarm_sequence(); }); }
  std::uint32_t fire_trigger(std::uint32_t pulse_width_us) override {
    return call([&] { return device().fire_trigger(pulse_width_us); });
  }
};

class LockedSpectrometer final : public drivers::Spectrometer, LockedCalls<drivers::Spectrometer> {
 public:
  explicit LockedSpectrometer(NamedDevice<drivers::Spectrometer>& d) : LockedCalls(d) {}
  drivers::SpectrometerInfo info() const override { return call([&] { return device().info(); }); }
  void set_integration_time_us(std::uint32_t us) override { call([&] { device().set_integration_time_us(us); }); }
  drivers::RawSpectrum read_raw_spectrum() override { return call([&] { return device().read_raw_spectrum(); }); }
  drivers::SpectrometerStatus read_status() override { return call([&] { return device().read_status(); }); }
};

std::string state_for_disk(session::OperationState state) { return session::state_name(state); }

nlohmann::json request_json(const CalibrationRequest& r) {
  return {{"controller", r.controller}, {"spectrometer", r.spectrometer}, {"drive_levels", r.drive_levels},
          {"warmup_ms", r.warmup_ms}};
}

session::OperationRecord record_from_json(const nlohmann::json& j, const std::filesystem::path& folder) {
  session::OperationRecord record;
  record.id = j.at("id").get<std::string>();
  record.kind = session::OperationKind::kCalibration;
  record.name = "calibration";
  record.state = session::parse_state(j.at("state").get<std::string>()).value_or(session::OperationState::kFailed);
  record.message = j.value("message", "");
  record.error = j.value("error", "");
  record.progress = record.state == session::OperationState::kSucceeded ? 1.0 : j.value("progress", 0.0);
  record.eta_seconds = 0;
  record.folder = std::filesystem::absolute(folder).string();
  record.created = record.updated = std::chrono::system_clock::time_point(
      std::chrono::seconds(j.value("created_unix_s", std::int64_t{0})));
  return record;
}

}  // namespace

Calibrations::Calibrations(std::filesystem::path root, std::filesystem::path configured_library, DeviceSet& devices,
                           OperationRunner& runner, files::StorageBudget* budget)
    : root_(std::move(root)), devices_(devices), runner_(runner), budget_(budget) {
  if (!configured_library.empty()) use_library(configured_library);  // DataError naming the file
}

void Calibrations::use_library(const std::filesystem::path& path) {
  auto library = std::make_shared<const calibration::LedLibrary>(calibration::load_led_library(path));
  std::lock_guard lock(mutex_);
  library_ = std::move(library);
  library_path_ = std::filesystem::absolute(path);
  mix_cache_.clear();
}

std::vector<session::OperationRecord> Calibrations::recover() {
  std::vector<session::OperationRecord> records;
  std::filesystem::path newest_library;
  std::string newest_id;
  if (!std::filesystem::is_directory(root_)) return records;  // made by the first run
  for (const auto& entry : std::filesystem::directory_iterator(root_)) {
    const auto file = entry.path() / kRecordFile;
    if (!entry.is_directory() || !std::filesystem::exists(file)) continue;
    files::remove_leftover_temporaries(entry.path());  // writes a crash interrupted
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(files::read_text_file(file, "JSON"));
      auto record = record_from_json(j, entry.path());
      if (!session::is_final(record.state)) {
        record.state = session::OperationState::kInterrupted;
        record.message = "the daemon stopped while this calibration was running";
        j["state"] = session::state_name(record.state);
        j["message"] = record.message;
        files::write_file_durably(file, j.dump(2) + "\n", budget_);
      }
      if (record.state == session::OperationState::kSucceeded && std::filesystem::exists(entry.path() / kLibraryFile) &&
          record.id > newest_id) {
        newest_id = record.id;
        newest_library = entry.path() / kLibraryFile;
      }
      records.push_back(std::move(record));
    } catch (const std::exception&) {
      continue;  // not a readable calibration record (e.g. a crash before its first write)
    }
  }
  if (!newest_library.empty()) use_library(newest_library);
  return records;
}

session::OperationRecord Calibrations::start(const CalibrationRequest& request) {
  calibration::CalibrationRunOptions options;
  if (!request.drive_levels.empty()) options.drive_levels = request.drive_levels;
  for (std::size_t i = 0; i < options.drive_levels.size(); ++i) {
    const double level = options.drive_levels[i];
    if (!(level > 0 && level <= 1))
      throw std::invalid_argument("drive_levels[" + std::to_string(i) + "]: must be in (0, 1]");
    if (i > 0 && !(level > options.drive_levels[i - 1]))
      throw std::invalid_argument("drive_levels[" + std::to_string(i) + "]: must be greater than the one before");
  }
  if (request.warmup_ms > 600000) throw std::invalid_argument("warmup_ms: at most 600000");
  std::string error;
  auto* led = devices_.led_controller(request.controller, &error);
  if (!led) throw std::invalid_argument("controller: " + error);
  auto* spectrometer = devices_.spectrometer(request.spectrometer, &error);
  if (!spectrometer) throw std::invalid_argument("spectrometer: " + error);
  // logic_error: FAILED_PRECONDITION over the API (the device is configured but away).
  if (!led->device) throw std::logic_error("controller: \"" + led->config.name + "\" is not open: " + led->open_error);
  if (!spectrometer->device)
    throw std::logic_error("spectrometer: \"" + spectrometer->config.name + "\" is not open: " + spectrometer->open_error);
  if (!devices_.reference_lamp)
    throw std::logic_error("no reference lamp is wired to this daemon: a calibration run measures the spectrometer's "
                           "response against it first (the virtual lab has one)");

  // Under the runner's lock, once nothing else runs: the folder, its first record, the operation.
  return runner_.start([&] {
    const std::string id = session::new_session_id("calibration");
    const auto folder = root_ / id;
    std::filesystem::create_directories(folder);
    const auto now = std::chrono::system_clock::now();
    files::write_file_durably(
        folder / kRecordFile,
        nlohmann::json{{"id", id},
                       {"state", "running"},
                       {"request", request_json(request)},
                       {"controller", led->config.name},
                       {"spectrometer", spectrometer->config.name},
                       {"created_unix_s", std::chrono::duration_cast<std::chrono::seconds>(now.time_since_epoch()).count()}}
                .dump(2) + "\n",
        budget_);
    session::OperationRecord record;
    record.id = id;
    record.kind = session::OperationKind::kCalibration;
    record.name = "calibration";
    record.state = session::OperationState::kRunning;
    record.message = "starting";
    record.folder = std::filesystem::absolute(folder).string();
    return OperationRunner::Start{record, [this, request, folder, led, spectrometer](RunningOperation& running) {
                                    return run(running, request, folder, led, spectrometer);
                                  }};
  });
}

OperationRunner::Outcome Calibrations::run(RunningOperation& running, const CalibrationRequest& request,
                                           const std::filesystem::path& folder, NamedDevice<drivers::LedController>* led,
                                           NamedDevice<drivers::Spectrometer>* spectrometer) {
  const std::string& id = running.id();
  calibration::CalibrationRunOptions options;
  if (!request.drive_levels.empty()) options.drive_levels = request.drive_levels;
  const double scale = devices_.lab_time_scale;
  if (scale > 1) {
    options.warm_up_s = 300.0 / scale;
    options.settle_s = 30.0 / scale;
    options.notes = "virtual lab: LED time runs " + std::to_string(static_cast<int>(scale)) + "x the wall clock";
  }
  if (request.warmup_ms > 0) options.warm_up_s = request.warmup_ms / 1000.0;
  options.notes += (options.notes.empty() ? "" : "; ") + std::string("chromod calibration ") + id;

  LockedLeds leds(*led);
  LockedSpectrometer meter(*spectrometer);
  calibration::CalibrationSummary summary;
  try {
    calibration::CalibrationRun run(leds, meter, devices_.reference_lamp, options);
    summary = run.run(running.progress());
  } catch (const std::exception& e) {
    summary.termination = calibration::CalibrationTermination::kDeviceError;
    summary.message = e.what();
  }
  session::OperationState state = session::OperationState::kFailed;
  switch (summary.termination) {
    case calibration::CalibrationTermination::kCompleted: state = session::OperationState::kSucceeded; break;
    case calibration::CalibrationTermination::kCancelled: state = session::OperationState::kCancelled; break;
    default: state = session::OperationState::kFailed;
  }
  std::string error = state == session::OperationState::kFailed ? summary.message : "";
  nlohmann::json record;
  try {
    if (state == session::OperationState::kSucceeded) {
      // save_led_library writes crash-safe (temporary, fsync, rename).
      calibration::save_led_library(summary.library, folder / kLibraryFile);
      use_library(folder / kLibraryFile);
    }
    record = nlohmann::json::parse(files::read_text_file(folder / kRecordFile, "JSON"));
    record["state"] = state_for_disk(state);
    record["message"] = summary.message;
    if (!error.empty()) record["error"] = error;
    record["summary"] = {{"termination", calibration::calibration_termination_name(summary.termination)},
                         {"spectra_measured", summary.spectra_measured},
                         {"elapsed_s", summary.elapsed_s},
                         {"linearity_ok", summary.linearity_ok}};
    if (state == session::OperationState::kSucceeded) {
      record["library"] = kLibraryFile;
      for (const auto& lin : summary.linearity)
        record["summary"]["linearity_max_deviation_percent"][std::string(spectral::led_type_name(lin.type))] =
            lin.max_deviation_percent;
    }
    files::write_file_durably(folder / kRecordFile, record.dump(2) + "\n", budget_);
  } catch (const std::exception& e) {
    state = session::OperationState::kFailed;
    error = std::string("writing the calibration result: ") + e.what();
  }
  return {state, error, summary.message, std::nullopt};
}

calibration::SolvedMix Calibrations::solve(const std::string& target, const std::string& objective, bool hold_chromaticity) const {
  calibration::session_mix_solver_options(objective, hold_chromaticity);  // a bad request is named before a missing library
  std::shared_ptr<const calibration::LedLibrary> library;
  std::string path;
  {
    std::lock_guard lock(mutex_);
    library = library_;
    path = library_path_.string();
  }
  if (!library)
    throw std::logic_error("no LED library: run a calibration (chromo calibrate) or configure led_library");
  calibration::SolvedMix solved = calibration::solve_session_mix(*library, target, objective, hold_chromaticity);
  solved.library = path;
  return solved;
}

std::optional<drivers::DriveLevels> Calibrations::solved_mix(const std::string& mix) const {
  {
    std::lock_guard lock(mutex_);
    if (!library_) return std::nullopt;
    if (auto found = mix_cache_.find(mix); found != mix_cache_.end()) return found->second;
  }
  auto levels = solve(mix, "camera", false).weights;
  std::lock_guard lock(mutex_);
  mix_cache_[mix] = levels;
  return levels;
}

std::shared_ptr<const calibration::LedLibrary> Calibrations::library() const {
  std::lock_guard lock(mutex_);
  return library_;
}

std::string Calibrations::library_path() const {
  std::lock_guard lock(mutex_);
  return library_path_.string();
}

}  // namespace chromo::daemon
