#include "chromo/daemon/internal/operations/calibrations.hpp"
#include "chromo/files/bounded_read.hpp"

#include <functional>
#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "chromo/calibration/calibration_run.hpp"
#include "chromo/calibration/led_library_io.hpp"
#include "chromo/calibration/library_check.hpp"
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

// The library file of one polarisation state in a run's folder.
std::string library_file_of(drivers::Polarisation state) {
  if (state == drivers::Polarisation::kUnpolarised) return kLibraryFile;
  return std::string("led-library-") + drivers::polarisation_name(state) + ".json";
}

// The states a calibration measures on this controller: cross and parallel
// when every LED type has banks (the session's polarised plan), else the only one.
std::vector<drivers::Polarisation> states_to_calibrate(const drivers::LedControllerInfo& info) {
  for (bool bank : info.polariser_banks)
    if (!bank) return {drivers::Polarisation::kUnpolarised};
  return {drivers::Polarisation::kCross, drivers::Polarisation::kParallel};
}

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

nlohmann::json figures_json(const calibration::MixFigures& f) {
  return {{"delta_uv_prime", f.delta_uv_prime}, {"camera_de00_mean", f.camera_de00.mean}, {"rmse", f.rmse}};
}

nlohmann::json check_json(const calibration::LibraryCheck& check) {
  nlohmann::json mixes = nlohmann::json::object();
  for (const auto& m : check.mixes) {
    mixes[m.mix] = {{"weights", m.weights}, {"prediction", figures_json(m.prediction)}};
    if (m.target) mixes[m.mix]["against_d65"] = figures_json(*m.target);
  }
  return {{"name", check.name}, {"mixes", mixes}};
}

// calibration.json's "adoption_check".
nlohmann::json comparison_json(const calibration::LibraryComparison& c) {
  return {{"candidate_no_worse", c.candidate_no_worse},
          {"worse", c.worse},
          {"in_use", check_json(c.in_use)},
          {"candidate", check_json(c.candidate)}};
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

// One CalibrationRun in `state`; its progress is [share_begin, share_end) of the operation's.
calibration::CalibrationSummary run_state(RunningOperation& running,
                                                        const calibration::CalibrationRunOptions& base_options,
                                                        NamedDevice<drivers::LedController>* led,
                                                        NamedDevice<drivers::Spectrometer>* spectrometer,
                                                        drivers::Polarisation state, double share_begin,
                                                        double share_end,
                                                        const std::function<void(bool on)>& reference_lamp) {
  calibration::CalibrationRunOptions options = base_options;
  options.polarisation = state;
  const files::Progress whole = running.progress();
  files::Progress part = whole;
  if (state != drivers::Polarisation::kUnpolarised)
    part.on_progress = [whole, share_begin, share_end, name = std::string(drivers::polarisation_name(state))](
                           double fraction, const std::string& step) {
      whole.report(share_begin + fraction * (share_end - share_begin), name + ": " + step);
    };
  LockedLeds leds(*led);
  LockedSpectrometer meter(*spectrometer);
  calibration::CalibrationSummary summary;
  try {
    calibration::CalibrationRun run(leds, meter, reference_lamp, options);
    summary = run.run(part);
  } catch (const std::exception& e) {
    summary.termination = calibration::CalibrationTermination::kDeviceError;
    summary.message = e.what();
  }
  return summary;
}

// The run's options: the request's drive levels and warm-up, the virtual
// lab's LED time scale (`lab_time_scale` > 1 shortens warm-up and settling),
// the operation id in the notes.
calibration::CalibrationRunOptions run_options(const CalibrationRequest& request, double lab_time_scale,
                                               const std::string& id) {
  calibration::CalibrationRunOptions options;
  if (!request.drive_levels.empty()) options.drive_levels = request.drive_levels;
  if (lab_time_scale > 1) {
    options.warm_up_s = 300.0 / lab_time_scale;
    options.settle_s = 30.0 / lab_time_scale;
    options.notes = "virtual lab: LED time runs " + std::to_string(static_cast<int>(lab_time_scale)) + "x the wall clock";
  }
  if (request.warmup_ms > 0) options.warm_up_s = request.warmup_ms / 1000.0;
  options.notes += (options.notes.empty() ? "" : "; ") + std::string("chromod calibration ") + id;
  return options;
}

session::OperationState operation_state(calibration::CalibrationTermination termination) {
  switch (termination) {
    case calibration::CalibrationTermination::kCompleted: return session::OperationState::kSucceeded;
    case calibration::CalibrationTermination::kCancelled: return session::OperationState::kCancelled;
    default: return session::OperationState::kFailed;
  }
}

using MeasuredStates = std::vector<std::pair<drivers::Polarisation, calibration::CalibrationSummary>>;

// What a finished run decided about adopting its library.
struct Adoption {
  std::optional<calibration::LibraryComparison> comparison;  // the check against the library in use
  std::string check_error;                                   // that check failed
  bool adopt_now = false;
};

// The new library against the one in use, on the LEDs now (unpolarised runs
// that succeeded); adopted when no worse, or when there is nothing to check.
// `check` compares a candidate library with the one in use (nullopt: nothing to compare).
Adoption decide_adoption(
    RunningOperation& running, session::OperationState state, const MeasuredStates& measured,
    const std::function<std::optional<calibration::LibraryComparison>(const calibration::LedLibrary&)>& check) {
  Adoption adoption;
  if (state == session::OperationState::kSucceeded && measured.size() == 1 &&
      measured.front().first == drivers::Polarisation::kUnpolarised) {
    running.progress().report(0.99, "checking the new library against the one in use");
    try {
      adoption.comparison = check(measured.front().second.library);
    } catch (const std::exception& e) {
      adoption.check_error = e.what();
    }
  }
  adoption.adopt_now = state == session::OperationState::kSucceeded && adoption.check_error.empty() &&
                       (!adoption.comparison || adoption.comparison->candidate_no_worse);
  return adoption;
}

// The operation's message: the run's, and whether (and why not) its library was adopted.
std::string outcome_message(const std::string& run_message, const Adoption& adoption, const std::string& id) {
  std::string message = run_message;
  if (adoption.comparison)
    message += adoption.adopt_now ? "; adopted: " + adoption.comparison->BriefReport()
                                  : "; NOT ADOPTED: " + adoption.comparison->BriefReport() +
                                        ". The daemon keeps its library; `chromo "
                                        "calibrate adopt " + id + " --reason TEXT` adopts this one";
  if (!adoption.check_error.empty())
    message += "; NOT ADOPTED: the check against the library in use failed: " + adoption.check_error +
               ". `chromo calibrate adopt " + id + " --reason TEXT` adopts it";
  return message;
}

// calibration.json's result fields, added to the record written at the start.
void add_result(nlohmann::json& record, session::OperationState state, const std::string& message,
                const std::string& error, const Adoption& adoption, const calibration::CalibrationSummary& summary,
                const MeasuredStates& measured) {
  record["state"] = state_for_disk(state);
  record["message"] = message;
  if (state == session::OperationState::kSucceeded) record["adopted"] = adoption.adopt_now;
  if (adoption.comparison) record["adoption_check"] = comparison_json(*adoption.comparison);
  if (!adoption.check_error.empty()) record["adoption_check"] = {{"error", adoption.check_error}};
  if (!error.empty()) record["error"] = error;
  record["summary"] = {{"termination", calibration::calibration_termination_name(summary.termination)},
                       {"spectra_measured", summary.spectra_measured},
                       {"elapsed_s", summary.elapsed_s},
                       {"linearity_ok", summary.linearity_ok}};
  for (const auto& [measured_state, measured_summary] : measured) {
    const std::string name = drivers::polarisation_name(measured_state);
    if (measured_state == drivers::Polarisation::kUnpolarised) {
      record["library"] = kLibraryFile;
    } else {
      record["libraries"][name] = library_file_of(measured_state);
      record["summary"]["states"][name] = {{"spectra_measured", measured_summary.spectra_measured},
                                           {"elapsed_s", measured_summary.elapsed_s},
                                           {"linearity_ok", measured_summary.linearity_ok}};
    }
    if (state == session::OperationState::kSucceeded)
      for (const auto& lin : measured_summary.linearity) {
        auto& deviations = record["summary"]["linearity_max_deviation_percent"];
        const std::string type(spectral::led_type_name(lin.type));
        const double earlier = deviations.contains(type) ? deviations[type].get<double>() : 0.0;
        deviations[type] = std::max(earlier, lin.max_deviation_percent);
      }
  }
}

}  // namespace

Calibrations::Calibrations(std::filesystem::path root, std::filesystem::path configured_library, DeviceSet& devices,
                           OperationRunner& runner, files::StorageBudget* budget, AdoptionCheck adoption)
    : root_(std::move(root)), adoption_(std::move(adoption)), devices_(devices), runner_(runner), budget_(budget) {
  if (!configured_library.empty()) use_library(configured_library);  // DataError naming the file
}

void Calibrations::use_library(const std::filesystem::path& path, drivers::Polarisation state) {
  auto library = std::make_shared<const calibration::LedLibrary>(calibration::load_led_library(path));
  std::lock_guard lock(mutex_);
  if (state == drivers::Polarisation::kUnpolarised) {
    library_ = std::move(library);
    library_path_ = std::filesystem::absolute(path);
  } else {
    state_libraries_[state] = std::move(library);
    state_library_paths_[state] = std::filesystem::absolute(path);
  }
  mix_cache_.clear();
}

std::vector<session::OperationRecord> Calibrations::recover() {
  std::vector<session::OperationRecord> records;
  std::filesystem::path newest_library, newest_state_folder;
  std::string newest_id, newest_state_id;
  if (!std::filesystem::is_directory(root_)) return records;  // made by the first run
  for (const auto& entry : std::filesystem::directory_iterator(root_)) {
    const auto file = entry.path() / kRecordFile;
    std::error_code unreadable;  // a loop of links is not a calibration, and must not stop the start
    if (!entry.is_directory(unreadable) || unreadable || !std::filesystem::exists(file, unreadable) || unreadable) continue;
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
      // A library found worse than the one in use then is not the daemon's until adopted (adopt()).
      const bool adopted = j.value("adopted", true);
      if (record.state == session::OperationState::kSucceeded && adopted &&
          std::filesystem::exists(entry.path() / kLibraryFile) && record.id > newest_id) {
        newest_id = record.id;
        newest_library = entry.path() / kLibraryFile;
      }
      if (record.state == session::OperationState::kSucceeded &&
          std::filesystem::exists(entry.path() / library_file_of(drivers::Polarisation::kCross)) &&
          std::filesystem::exists(entry.path() / library_file_of(drivers::Polarisation::kParallel)) &&
          record.id > newest_state_id) {
        newest_state_id = record.id;
        newest_state_folder = entry.path();
      }
      records.push_back(std::move(record));
    } catch (const std::exception&) {
      continue;  // not a readable calibration record (e.g. a crash before its first write)
    }
  }
  if (!newest_library.empty()) use_library(newest_library);
  if (!newest_state_folder.empty())
    for (auto state : {drivers::Polarisation::kCross, drivers::Polarisation::kParallel})
      use_library(newest_state_folder / library_file_of(state), state);
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
  const calibration::CalibrationRunOptions options = run_options(request, devices_.lab_time_scale, id);
  std::vector<drivers::Polarisation> states{drivers::Polarisation::kUnpolarised};
  try {
    states = states_to_calibrate(LockedLeds(*led).info());
  } catch (const std::exception&) {
    // the run itself reports the unreachable controller
  }
  // One run per state; the libraries are kept in memory until every run has succeeded.
  MeasuredStates measured;
  calibration::CalibrationSummary summary;
  for (std::size_t i = 0; i < states.size(); ++i) {
    summary = run_state(running, options, led, spectrometer, states[i], static_cast<double>(i) / states.size(),
                        static_cast<double>(i + 1) / states.size(), devices_.reference_lamp);
    if (states.size() > 1) summary.message = std::string(drivers::polarisation_name(states[i])) + ": " + summary.message;
    if (summary.termination != calibration::CalibrationTermination::kCompleted) break;
    measured.emplace_back(states[i], summary);
  }
  session::OperationState state = operation_state(summary.termination);
  std::string error = state == session::OperationState::kFailed ? summary.message : "";
  const Adoption adoption = decide_adoption(running, state, measured, [&](const calibration::LedLibrary& candidate) {
    return check_adoption(candidate, led, spectrometer);
  });
  const std::string message = outcome_message(summary.message, adoption, id);
  try {
    // Every state's library measured so far is written (save_led_library is
    // crash-safe: temporary, fsync, rename), so a failed later state keeps the
    // earlier ones in the folder; the daemon adopts them only when all succeeded.
    for (const auto& [measured_state, measured_summary] : measured)
      calibration::save_led_library(measured_summary.library, folder / library_file_of(measured_state));
    if (adoption.adopt_now)
      for (const auto& [measured_state, measured_summary] : measured)
        use_library(folder / library_file_of(measured_state), measured_state);
    nlohmann::json record = nlohmann::json::parse(files::read_text_file(folder / kRecordFile, "JSON"));
    add_result(record, state, message, error, adoption, summary, measured);
    files::write_file_durably(folder / kRecordFile, record.dump(2) + "\n", budget_);
  } catch (const std::exception& e) {
    state = session::OperationState::kFailed;
    error = std::string("writing the calibration result: ") + e.what();
  }
  return {state, error, message, std::nullopt};
}

std::optional<calibration::LibraryComparison> Calibrations::check_adoption(
    const calibration::LedLibrary& candidate, NamedDevice<drivers::LedController>* led,
    NamedDevice<drivers::Spectrometer>* spectrometer) {
  if (!candidate.instrument.response_calibration) return std::nullopt;  // not measured by a run: nothing to compare with
  std::shared_ptr<const calibration::LedLibrary> in_use_library;
  std::filesystem::path in_use_path;
  {
    std::lock_guard lock(mutex_);
    in_use_library = library_;
    in_use_path = library_path_;
  }
  const calibration::LedLibrary nominal = calibration::nominal_led_library();
  calibration::LibraryUnderCheck in_use{
      in_use_library ? "the library in use (" + in_use_path.parent_path().filename().string() + ")"
                     : "the configured mixes (nominal built-in library)",
      in_use_library ? in_use_library.get() : &nominal,
      {}};
  calibration::LibraryUnderCheck next{"the new library", &candidate, {}};
  for (const std::string& mix : adoption_.mixes) {
    if (in_use_library) in_use.mixes.emplace_back(mix, calibration::solve_session_mix(*in_use_library, mix, "camera", false).weights);
    else if (adoption_.configured_mix) in_use.mixes.emplace_back(mix, adoption_.configured_mix(mix));
    else return std::nullopt;  // nothing in use to compare with
    next.mixes.emplace_back(mix, calibration::solve_session_mix(candidate, mix, "camera", false).weights);
  }
  LockedLeds leds(*led);
  LockedSpectrometer meter(*spectrometer);
  return calibration::compare_libraries_on_leds(leds, meter, candidate.instrument.response_calibration->correction, in_use,
                                                next);
}

std::string Calibrations::adopt(const std::string& id, const std::string& reason) {
  if (reason.empty()) throw std::invalid_argument("reason: say why this library is adopted (it is audited)");
  if (id.empty() || id.find('/') != std::string::npos || id.find("..") != std::string::npos)
    throw std::invalid_argument("id: not a calibration id");
  const auto folder = root_ / id;
  const auto file = folder / kRecordFile;
  std::error_code ignored;
  if (!std::filesystem::is_regular_file(file, ignored)) throw std::invalid_argument("id: no calibration \"" + id + "\"");
  nlohmann::json record = nlohmann::json::parse(files::read_text_file(file, "JSON"));
  if (record.value("state", "") != session::state_name(session::OperationState::kSucceeded))
    throw std::logic_error("calibration " + id + " did not succeed: there is no library to adopt");
  if (!std::filesystem::is_regular_file(folder / kLibraryFile, ignored))
    throw std::logic_error("calibration " + id + " has no unpolarised library (led-library.json)");
  use_library(folder / kLibraryFile);  // DataError naming the file before anything is written
  record["adopted"] = true;
  record["adopted_reason"] = reason;
  files::write_file_durably(file, record.dump(2) + "\n", budget_);
  return library_path();
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

drivers::Polarisation Calibrations::library_state(drivers::Polarisation state) const {
  return state_libraries_.count(state) ? state : drivers::Polarisation::kUnpolarised;
}

std::optional<drivers::DriveLevels> Calibrations::solved_mix(const std::string& mix, drivers::Polarisation state) const {
  std::shared_ptr<const calibration::LedLibrary> library;
  std::pair<std::string, drivers::Polarisation> key;
  {
    std::lock_guard lock(mutex_);
    key = {mix, library_state(state)};
    library = key.second == drivers::Polarisation::kUnpolarised ? library_ : state_libraries_.at(key.second);
    if (!library) return std::nullopt;
    if (auto found = mix_cache_.find(key); found != mix_cache_.end()) return found->second;
  }
  auto levels = calibration::solve_session_mix(*library, mix, "camera", false).weights;
  std::lock_guard lock(mutex_);
  mix_cache_[key] = levels;
  return levels;
}

std::shared_ptr<const calibration::LedLibrary> Calibrations::library_for(drivers::Polarisation state) const {
  std::lock_guard lock(mutex_);
  const auto slot = library_state(state);
  return slot == drivers::Polarisation::kUnpolarised ? library_ : state_libraries_.at(slot);
}

std::map<drivers::Polarisation, session::StateLedLibrary> Calibrations::measured_state_libraries() const {
  std::lock_guard lock(mutex_);
  std::map<drivers::Polarisation, session::StateLedLibrary> libraries;
  for (const auto& [state, library] : state_libraries_)
    libraries.emplace(state, session::StateLedLibrary{*library, state_library_paths_.at(state).string()});
  return libraries;
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
