#include "chromo/daemon/daemon.hpp"
#include "chromo/daemon/log_line.hpp"

#include <algorithm>
#include <cstdio>

#include <fstream>
#include <iostream>
#include <set>

#include <stdexcept>
#include <thread>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/files/bounded_read.hpp"
#include "chromo/session/derived_data.hpp"
#include "chromo/daemon/internal/capture/online_estimator.hpp"
#include "chromo/daemon/internal/capture/sequencer.hpp"
#include "chromo/drivers/camera/aravis_camera.hpp"
#include "chromo/drivers/device_error.hpp"

namespace chromo::daemon {

Daemon::Daemon(DaemonConfig config, DeviceSet devices, FrameConsumer* estimator)
    : config_(std::move(config)),
      devices_(std::move(devices)),
      estimator_(estimator),
      budget_(config_.storage_limit_bytes),
      store_(config_.sessions_dir, &budget_) {
  std::vector<std::string> skipped;
  for (auto& info : store_.recover(&skipped)) operations_.add_past(std::move(info.record));
  for (const auto& reason : skipped) log_line(LogLevel::kWarning, "sessions: skipped (not recovered): " + reason);
  // A new library is checked on the standard plan's mixes before it replaces the one in use.
  AdoptionCheck adoption;
  if (config_.capture.blue_ratio > 0) {
    char ratio[32];
    std::snprintf(ratio, sizeof ratio, "%g", config_.capture.blue_ratio);  // as session::standard_plan names them
    adoption.mixes = {"d65", std::string("w57+blue:") + ratio, std::string("w57:") + ratio};
  }
  adoption.configured_mix = [this](const std::string& mix) { return configured_mix(mix); };
  calibrations_ = std::make_unique<Calibrations>(config_.sessions_dir / "calibrations", config_.led_library, devices_,
                                                 runner_, &budget_, std::move(adoption));
  for (auto& record : calibrations_->recover()) operations_.add_past(std::move(record));
  if (!estimator_ && config_.estimation.enabled) {
    owned_estimator_ = make_online_estimator(config_.estimation, &budget_,
                                             [this] { return calibrations_->library_path(); },
                                             [this] { return calibrations_->measured_state_libraries(); },
                                             devices_.own_films);
    estimator_ = owned_estimator_.get();
  }
}

Daemon::~Daemon() { runner_.cancel_and_join(); }

std::vector<DeviceReport> Daemon::probe_devices() {
  std::vector<DeviceReport> reports;
  auto base = [](const DeviceConfig& config) {
    DeviceReport report;
    report.name = config.name;
    report.backend = config.backend;
    report.address = config.address;
    report.kind = config.kind;
    return report;
  };
  auto failed = [](DeviceReport& report, const std::exception& error) {
    report.health = DeviceReport::Health::kUnreachable;
    if (auto* device = dynamic_cast<const drivers::DeviceError*>(&error);
        device && device->kind() == drivers::DeviceError::Kind::kFault)
      report.health = DeviceReport::Health::kFault;
    report.detail = error.what();
  };
  for (auto& led : devices_.led_controllers) {
    auto report = base(led->config);
    if (!led->device) {
      report.health = DeviceReport::Health::kUnreachable;
      report.detail = led->open_error;
    } else {
      try {
        std::lock_guard lock(led->mutex);
        auto info = led->device->info();
        report.info = {{"model", info.model}, {"serial", info.serial}, {"firmware", info.firmware_version},
                       {"drive_mode", info.drive_mode == drivers::DriveMode::kPwmDuty ? "pwm_duty" : "constant_current"},
                       // "yes" when some LED type has banks (polarised steps need them), else "no"
                       {"polariser_banks", info.has_polarisers() ? "yes" : "no"}};
        auto status = led->device->read_status();
        if (status.controller_faults != 0) {
          report.health = DeviceReport::Health::kFault;
          report.detail = "controller faults 0x" + std::to_string(status.controller_faults);
        }
        for (std::size_t i = 0; i < status.channel_faults.size(); ++i)
          if (status.channel_faults[i] != 0) {
            report.health = DeviceReport::Health::kFault;
            report.detail += std::string(report.detail.empty() ? "" : "; ") + "channel " +
                             std::string(spectral::led_type_name(spectral::kAllLedTypes[i])) + " faults " +
                             std::to_string(status.channel_faults[i]);
          }
      } catch (const std::exception& error) {
        failed(report, error);
      }
    }
    reports.push_back(std::move(report));
  }
  for (auto& camera : devices_.cameras) {
    auto report = base(camera->config);
    if (!camera->device) {
      report.health = DeviceReport::Health::kUnreachable;
      report.detail = camera->open_error;
    } else {
      try {
        std::lock_guard lock(camera->mutex);
        auto info = camera->device->info();
        report.info = {{"vendor", info.vendor}, {"model", info.model}, {"serial", info.serial},
                       {"sensor", std::to_string(info.sensor_width) + "x" + std::to_string(info.sensor_height)}};
        // A GigE Vision camera's info is what it said when opened: whether it
        // answers now is its link (heartbeat and watchdog, aravis_camera.hpp).
        if (auto* aravis = dynamic_cast<const drivers::AravisCamera*>(camera->device.get()); aravis && !aravis->link_up()) {
          report.health = DeviceReport::Health::kUnreachable;
          report.detail = "the camera's link is lost (it stopped answering its control channel)";
        }
      } catch (const std::exception& error) {
        failed(report, error);
      }
    }
    reports.push_back(std::move(report));
  }
  for (auto& spectrometer : devices_.spectrometers) {
    auto report = base(spectrometer->config);
    if (!spectrometer->device) {
      report.health = DeviceReport::Health::kUnreachable;
      report.detail = spectrometer->open_error;
    } else {
      try {
        std::lock_guard lock(spectrometer->mutex);
        auto info = spectrometer->device->info();
        report.info = {{"model", info.model}, {"serial", info.serial}, {"pixels", std::to_string(info.pixel_count)}};
        spectrometer->device->read_status();
      } catch (const std::exception& error) {
        failed(report, error);
      }
    }
    reports.push_back(std::move(report));
  }
  return reports;
}

drivers::DriveLevels Daemon::resolve_mix(const std::string& mix, drivers::Polarisation state) const {
  if (auto solved = calibrations_->solved_mix(mix, state)) return *solved;
  return configured_mix(mix);
}

drivers::DriveLevels Daemon::configured_mix(const std::string& mix) const {
  auto found = config_.mixes.find(mix);
  if (found != config_.mixes.end()) return found->second;
  // "w57:R": W57 alone as in "w57+blue:R", whose W57 level is the configured w57+blue's.
  if (mix.rfind("w57:", 0) == 0) {
    if (auto base = config_.mixes.find("w57"); base != config_.mixes.end()) return base->second;
  }
  // "w57+blue:R": the blue level scaled by R relative to the configured w57+blue.
  const std::string prefix = "w57+blue:";
  if (mix.rfind(prefix, 0) == 0) {
    auto base = config_.mixes.find("w57+blue");
    if (base != config_.mixes.end()) {
      auto levels = base->second;
      auto& blue = levels[static_cast<std::size_t>(spectral::led_type_index(spectral::LedType::kBlue))];
      blue = std::min(1.0, blue * std::stod(mix.substr(prefix.size())));
      return levels;
    }
  }
  throw std::invalid_argument("mix \"" + mix + "\": no weights for it (configure \"mixes\" or run a calibration)");
}

session::CaptureSources Daemon::light_sources() const {
  std::string library = config_.estimation.led_library;
  if (library.empty()) library = calibrations_->library_path();
  if (library.empty()) library = config_.led_library.string();
  // The daemon's own library or the nominal one: never the user's newest (another daemon's).
  if (library.empty()) library = session::kNominalLedLibrary;
  session::CaptureSources sources = session::resolve_capture_sources(
      library, config_.estimation.camera_sensitivity, config_.estimation.white_reflectance);
  // A frame lit through a bank takes its illuminant from that state's measured
  // library (the polarisers' spectral transmission is in it), unless the
  // estimation's library is pinned by configuration.
  if (config_.estimation.led_library.empty()) sources.led_library_of_state = calibrations_->measured_state_libraries();
  return sources;
}

session::PlanHazard Daemon::plan_hazard(const session::SessionPlan& plan,
                                        const std::map<std::string, double>& exposure_us_of_step) const {
  const session::CaptureSources sources = light_sources();
  auto levels = [this](const session::Step& step) {
    switch (step.illumination.kind) {
      case session::Illumination::Kind::kDark: return drivers::DriveLevels{};
      case session::Illumination::Kind::kWeights: return step.illumination.weights;
      case session::Illumination::Kind::kMix: return resolve_mix(step.illumination.mix, step.polarisation);
    }
    return drivers::DriveLevels{};
  };
  return session::plan_blue_light_hazard(plan, levels, sources.led_library, config_.hazard, exposure_us_of_step);
}

session::StandardPlanOptions Daemon::standard_plan_options() const {
  session::StandardPlanOptions options;
  options.frames_per_camera = config_.capture.frames_per_capture;
  options.reference_frames = config_.capture.reference_frames;
  options.blue_ratio = config_.capture.blue_ratio;
  if (config_.capture.exposure_per_capture) {
    options.meter_white_share = config_.capture.white_share;
    options.subject_fill = config_.capture.subject_fill;
    options.subject_percentile = config_.capture.subject_percentile;
    options.max_subject_exposure_ratio = config_.capture.max_subject_exposure_ratio;
  }
  options.polarised = config_.capture.polarised_plan == "on" ||
                      (config_.capture.polarised_plan == "auto" && controller_polarised_everywhere());
  return options;
}

bool Daemon::controller_polarised_everywhere() const {
  if (devices_.led_controllers.size() != 1) return false;  // the session's controller is the only one (led_controller(""))
  auto& led = devices_.led_controllers.front();
  if (!led->device) return false;
  std::lock_guard device_lock(led->mutex);
  const auto banks = led->device->info().polariser_banks;
  return std::all_of(banks.begin(), banks.end(), [](bool bank) { return bank; });
}

session::OperationRecord Daemon::start_calibration(const CalibrationRequest& request) {
  ensure_idle();  // before the request's checks, as the runner checks again
  previews_.stop_free_runs();  // the live view's free runs leave the cameras to the calibration
  return calibrations_->start(request);
}

std::string Daemon::adopt_calibration(const std::string& id, const std::string& reason) {
  ensure_idle();
  return calibrations_->adopt(id, reason);
}

void Daemon::ensure_idle() const {
  if (operations_.any_active()) throw std::logic_error("another session or calibration is running");
}

void Daemon::check_plan_runs_here(const session::SessionPlan& plan) {
  std::string error;
  if (!plan.IsValid(&error)) throw std::invalid_argument("plan." + error);
  for (std::size_t i = 0; i < plan.steps.size(); ++i)
    if (plan.steps[i].illumination.kind == session::Illumination::Kind::kMix) {
      try {
        resolve_mix(plan.steps[i].illumination.mix, plan.steps[i].polarisation);
      } catch (const std::invalid_argument& failure) {
        throw std::invalid_argument("plan.steps[" + std::to_string(i) + "].mix: " + failure.what());
      }
    }
  const session::PlanHazard hazard = plan_hazard(plan);
  if (!hazard.within_limit())
    throw std::invalid_argument(hazard.describe() + ": beyond the limit, refused (hazard.limit_J_per_m2_sr, docs/config.md)");
  std::string led_error;
  auto* led = devices_.led_controller("", &led_error);
  if (!led) throw std::runtime_error("LED controller: " + led_error);
  if (devices_.cameras.empty()) throw std::runtime_error("no camera configured");
  if (led->device) {  // polarised steps need polariser banks (docs/polarisation.md)
    bool has_polarisers = false;
    {
      std::lock_guard device_lock(led->mutex);
      has_polarisers = led->device->info().has_polarisers();
    }
    for (std::size_t i = 0; i < plan.steps.size() && !has_polarisers; ++i)
      if (plan.steps[i].polarisation != drivers::Polarisation::kUnpolarised)
        throw std::invalid_argument("plan.steps[" + std::to_string(i) + "].polarisation: " +
                                    drivers::polarisation_name(plan.steps[i].polarisation) + ", but LED controller \"" +
                                    led->config.name +
                                    "\" has no polariser banks: choose the unpolarised plan (docs/polarisation.md; the "
                                    "standard plan's default: capture.polarised_plan \"auto\" or \"off\")");
  }
  if (plan.timing == session::Timing::kHardware && led->device) {
    // The controller holds the whole sequence: a resting state plus one state per frame.
    int capacity = 0;
    {
      std::lock_guard device_lock(led->mutex);
      capacity = led->device->info().sequence_capacity;
    }
    const auto states = plan.frames_per_camera_total() + 1;
    if (capacity > 0 && states > static_cast<std::uint64_t>(capacity))
      throw std::invalid_argument("plan.timing: hardware timing needs " + std::to_string(states) +
                                  " sequence states (one per frame and a resting state); controller \"" +
                                  led->config.name + "\" holds " + std::to_string(capacity));
  }
}

session::OperationRecord Daemon::start_session(session::SessionPlan plan, const std::string& subject,
                                               const SessionPeople& people) {
  if (subject.size() > session::kMaxTextBytes) throw std::invalid_argument("subject: longer than 4096 bytes");
  check_plan_runs_here(plan);
  const session::SessionProvenance provenance = session_provenance(plan, people);
  const session::PlanHazard hazard = plan_hazard(plan);

  // Under the runner's lock, once nothing else runs: the folder, the first journal record, the operation.
  return runner_.start([&] {
    nlohmann::json devices = nlohmann::json::array();
    for (auto& d : devices_.led_controllers) devices.push_back({{"name", d->config.name}, {"kind", "led_controller"}, {"backend", d->config.backend}});
    for (auto& d : devices_.cameras) devices.push_back({{"name", d->config.name}, {"kind", "camera"}, {"backend", d->config.backend}});
    auto created = store_.create(plan, subject, devices, &provenance);
    const std::uint64_t expected = plan.frames_per_camera_total() * devices_.cameras.size();
    created.journal->append({{"type", "session_started"}, {"expected_frames", expected}});
    const auto hazard_record = std::make_shared<session::HazardRecord>();
    created.journal->append(
        hazard_record->record(hazard, "planned (metered steps: their first guess; checked again once metered)"));

    session::OperationRecord record;
    record.id = created.id;
    record.kind = session::OperationKind::kSession;
    record.name = plan.name;
    record.state = session::OperationState::kPending;
    record.folder = std::filesystem::absolute(created.folder).string();
    record.step_count = static_cast<int>(plan.steps.size());
    record.expected_frames = expected;
    record.subject = subject;
    record.study = people.study;
    record.operator_name = people.operator_name;
    std::shared_ptr<session::Journal> journal(std::move(created.journal));
    return OperationRunner::Start{record, [this, plan, provenance, journal, hazard_record,
                                           folder = created.folder](RunningOperation& running) {
                                    return run_session(running, plan, provenance, {journal, hazard_record}, folder);
                                  }};
  });
}

namespace {

// A session's last records: the pipeline's counters and the final state. A
// full disk leaves them unwritten (the folder stays valid; the next start
// reports the session as interrupted) and fails the outcome if it succeeded.
void journal_final_records(session::Journal& journal, const session::PipelineCounters& counters,
                           SequencerOutcome& outcome) {
  try {
    journal.append(session::counters_record(counters));
    nlohmann::json final_state{{"type", "state"}, {"state", session::state_name(outcome.state)}};
    if (!outcome.error.empty()) final_state["error"] = outcome.error;
    journal.append(final_state);
  } catch (const std::exception& error) {
    // The disk is full: the final record could not be written. The folder
    // stays valid; the next start reports the session as interrupted.
    if (outcome.error.empty()) outcome = {session::OperationState::kFailed, error.what()};
  }
}

}  // namespace

// The sequencer's context for a session: its plan, journal, pipeline and
// devices, and the daemon's hooks (mixes, the sphere, the live view, the
// metering's first guess, the blue-light hazard check). Stops the live
// view's free runs: the cameras are the session's now.
SequencerContext Daemon::sequencer_context(RunningOperation& running, const session::SessionPlan& plan,
                                           const SessionRecords& records, FramePipeline& pipeline) {
  const std::shared_ptr<session::Journal>& journal = records.journal;
  const std::string& id = running.id();
  SequencerContext context;
  context.id = id;
  context.plan = plan;
  context.journal = journal.get();
  context.pipeline = &pipeline;
  context.operations = &operations_;
  context.control = &running.control();
  context.led = devices_.led_controller("", nullptr);
  for (auto& camera : devices_.cameras) context.cameras.push_back(camera.get());
  previews_.stop_free_runs();  // the cameras are the session's now; the live view shows its frames
  context.on_frame_seen = [this, source = "session:" + id](const std::string& camera, const drivers::Frame& frame,
                                                         double exposure_us) {
    previews_.offer(camera, frame, exposure_us, source);
  };
  context.resolve_mix = [this](const std::string& mix, drivers::Polarisation state) { return resolve_mix(mix, state); };
  context.place_in_sphere = devices_.place_in_sphere;
  try {
    const session::CaptureSources sources = light_sources();
    context.predict_white_rgb = [sources](const drivers::DriveLevels& drive) -> std::optional<std::array<double, 3>> {
      spectral::Spectrum light;
      for (auto type : spectral::kAllLedTypes)
        light += sources.led_library.led(type).spectrum_per_unit_drive() *
                 drive[static_cast<std::size_t>(spectral::led_type_index(type))];
      std::array<double, 3> rgb{};
      for (int c = 0; c < 3; ++c) rgb[c] = (sources.camera.rgb[c].values() * light.values()).sum() * sources.white_reflectance;
      return rgb;
    };
  } catch (const std::exception&) {
    // No library or camera data: metering starts from the plan's exposure each time.
  }
  context.check_hazard = [this, plan, journal, hazard = records.hazard](const std::map<std::string, double>& exposures) {
    const session::PlanHazard metered = plan_hazard(plan, exposures);
    journal->append(hazard->record(metered, "metered"));
    return metered.within_limit() ? std::string()
                                  : metered.describe() + ": beyond the limit with the metered exposures, refused "
                                                         "before the subject's first frame (hazard.limit_J_per_m2_sr)";
  };
  context.frame_timeout_ms = config_.frame_timeout_ms;
  context.frame_attempts = config_.frame_attempts;
  return context;
}

OperationRunner::Outcome Daemon::run_session(RunningOperation& running, const session::SessionPlan& plan,
                                             const session::SessionProvenance& provenance,
                                             const SessionRecords& records, const std::filesystem::path& folder) {
  const std::shared_ptr<session::Journal>& journal = records.journal;
  const std::string& id = running.id();
  SequencerOutcome outcome;
  session::PipelineCounters counters;
  auto log_event = [&](const std::string& text) {
    Event event;
    event.kind = Event::Kind::kLog;
    event.session_id = id;
    event.log = text;
    events_.publish(std::move(event));
  };
  // Every stored frame, summed once as it is stored: derived data is written
  // from these sums and the on-line estimator's captures read them (a
  // session re-processed from its folder fills them from the stored frames:
  // session::add_stored_frames).
  const auto stored_sums = std::make_shared<session::SessionFrameSums>();
  if (estimator_) {
    std::vector<std::string> cameras;
    for (auto& camera : devices_.cameras) cameras.push_back(camera->config.name);
    estimator_->begin_session({id, folder, plan, {[&, id](double fraction, const std::string& message) {
                                 operations_.update(id, [&](session::OperationRecord& r) {
                                   r.message = message + " " + std::to_string(static_cast<int>(fraction * 100)) + "%";
                                   r.eta_seconds = -1;  // the capture's estimate says nothing of the maps' time
                                 });
                               }, {}}, cameras, provenance, stored_sums, records.hazard});
  }
  std::string stored_sums_error;
  {
    FramePipeline pipeline(
        folder, *journal, &budget_,
        {config_.storage_queue_frames, config_.estimator_queue_frames, stored_sums.get()}, estimator_,
        [&](const StoredFrame& stored) {
          Event event;
          event.kind = Event::Kind::kFrame;
          event.session_id = id;
          event.step = stored.frame->record.step;
          event.camera = stored.frame->record.camera;
          event.frame_index = stored.index;
          events_.publish(std::move(event));
        },
        [&](std::uint64_t skipped) {
          log_event("session " + id + ": the on-line estimator is behind (its queue of " +
                    std::to_string(config_.estimator_queue_frames) + " frames is full; " + std::to_string(skipped) +
                    " frames skipped so far, read back from storage at the end; storage is not delayed)");
        });
    SequencerContext context = sequencer_context(running, plan, records, pipeline);
    try {
      journal->append({{"type", "state"}, {"state", "running"}});
      outcome = run_sequence(context);
    } catch (const std::exception& error) {
      outcome = {session::OperationState::kFailed, error.what()};
    }
    // Every frame is stored, so the sums are complete: derived data is
    // written in the background (its own threads at the lowest priority)
    // while the on-line estimator makes the maps, which come first on the
    // cores; the results record does not wait for it.
    pipeline.drain_storage();
    stored_sums_error = pipeline.stored_sums_error();
    std::jthread derived;  // joined before the final records, or on the way out of an exception
    std::string derived_error;
    if (outcome.state == session::OperationState::kSucceeded) {
      operations_.update(id, [](session::OperationRecord& r) { r.message = "writing derived data"; });
      derived = std::jthread([&] {
        try {
          if (!stored_sums_error.empty()) throw std::runtime_error(stored_sums_error);
          session::write_derived_data(folder, plan, *stored_sums, config_.estimation.white_reflectance, *journal,
                                      &budget_, {.background = true});
        } catch (const std::exception& error) {
          derived_error = std::string("derived data: ") + error.what();
        }
      });
    }
    pipeline.drain();
    counters = pipeline.counters();
    if (estimator_) {
      // The maps: catches up on skipped frames, estimates if not done yet, and
      // says whether results are available (before the final state record).
      nlohmann::json results = estimator_->end_session({outcome.state == session::OperationState::kSucceeded});
      if (!results.is_null()) {
        counters.estimator_read_back = results.value("frames_read_back", std::uint64_t{0});
        try {
          journal->append(results);
        } catch (const std::exception& error) {
          outcome = {session::OperationState::kFailed, std::string("results record: ") + error.what()};
        }
        log_event("session " + id + ": results " + results.value("state", "") +
                  (results.contains("reason") ? ": " + results.value("reason", "") : ""));
      }
    }
    if (derived.joinable()) derived.join();
    if (!derived_error.empty() && outcome.state == session::OperationState::kSucceeded)
      outcome = {session::OperationState::kFailed, derived_error};
  }
  journal_final_records(*journal, counters, outcome);
  // The runner's final update: "done" or the state's name, with the counters.
  return {outcome.state, outcome.error, std::nullopt, counters};
}

std::optional<session::SessionInfo> Daemon::session(const std::string& id) const {
  if (!session::is_valid_name(id)) return std::nullopt;
  auto folder = store_.root() / id;
  if (!std::filesystem::exists(folder / "session.json")) return std::nullopt;
  session::SessionInfo info =
      session_reads_.get(folder, [this](const std::filesystem::path& f) { return store_.read_session(f); });
  if (auto live = operations_.get(id)) info.record = *live;
  return info;
}

Daemon::DeletedSession Daemon::delete_session(const std::string& id) {
  namespace fs = std::filesystem;
  std::lock_guard lock(delete_mutex_);
  auto record = operations_.get(id);
  if (!session::is_valid_name(id) || id == "." || id == ".." || !record || record->kind != session::OperationKind::kSession ||
      !fs::exists(store_.root() / id / "session.json"))
    throw std::invalid_argument("id: no session \"" + id + "\"");
  if (!session::is_final(record->state))
    throw std::logic_error("id: session \"" + id + "\" is " + session::state_name(record->state) + "; cancel it first");
  const fs::path folder = store_.root() / id;
  DeletedSession deleted;
  // Cache entries: this session's forward and inverse tables, unless another
  // session's results name the same entry.
  const std::set<std::string> only_here = table_references_.named_only_by(store_.root(), folder);
  for (const auto& entry : fs::recursive_directory_iterator(folder))
    if (entry.is_regular_file()) ++deleted.files, deleted.bytes += entry.file_size();
  operations_.remove(id);
  fs::remove_all(folder);
  table_references_.forget(folder);
  files::fsync_directory(store_.root());
  const fs::path cache = config_.estimation.cache_dir.empty() ? estimation::ForwardTable::default_cache_dir()
                                                               : fs::path(config_.estimation.cache_dir);
  for (const auto& name : only_here) {
    std::error_code error;
    if (fs::remove(cache / name, error)) deleted.cache_entries.push_back(name);
  }
  return deleted;
}

}  // namespace chromo::daemon
