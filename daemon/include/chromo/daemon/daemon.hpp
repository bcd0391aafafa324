#pragma once
// Daemon: everything chromod runs, without the network. The gRPC services
// (src/api/services/, one file each) are a thin translation of the API onto
// these calls, and tests can drive a Daemon directly.
//
// Owns the devices, the operation registry and event bus, the session store.
// One session or calibration runs at a time, on the thread of the daemon's
// OperationRunner (operation_runner.hpp); starting a second gets
// FAILED_PRECONDITION from the API (std::logic_error here).
//
// Lifetime: the destructor cancels a running session or calibration and
// joins its thread; a session then ends CANCELLED on disk. Thread-safe.

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "chromo/daemon/internal/operations/calibrations.hpp"
#include "chromo/daemon/internal/operations/lab_checks.hpp"
#include "chromo/daemon/config.hpp"
#include "chromo/daemon/internal/capture/frame_pipeline.hpp"
#include "chromo/session/session_captures.hpp"
#include "chromo/daemon/internal/devices/device_set.hpp"
#include "chromo/files/durable_file.hpp"
#include "chromo/daemon/internal/operations/operation_runner.hpp"
#include "chromo/daemon/internal/operations/operations.hpp"
#include "chromo/daemon/internal/operations/table_cache_references.hpp"
#include "chromo/daemon/internal/capture/frame_pipeline.hpp"
#include "chromo/daemon/internal/capture/preview_hub.hpp"
#include "chromo/daemon/internal/capture/white_balance.hpp"
#include "chromo/session/session_read_cache.hpp"
#include "chromo/session/session_store.hpp"

namespace chromo::daemon {

struct SequencerContext;  // internal/capture/sequencer.hpp

struct DeviceReport {
  std::string name, backend, address;
  DeviceKind kind;
  enum class Health { kOk, kUnreachable, kFault } health = Health::kOk;
  std::string detail;
  std::map<std::string, std::string> info;
};

// Who ran a session and for what study (free text, each at most 4096 bytes,
// no control characters; checked by the API): recorded in its provenance.
struct SessionPeople {
  std::string operator_name;
  std::string study;
};

class Daemon {
 public:
  // Opens the devices (config.devices, or `devices` when given: the caller's
  // virtual lab), recovers the sessions folder. Without an `estimator`, the
  // daemon runs its own on-line estimator (online_estimator.hpp) unless
  // config.estimation.enabled is false.
  Daemon(DaemonConfig config, DeviceSet devices, FrameConsumer* estimator = nullptr);
  ~Daemon();

  const DaemonConfig& config() const { return config_; }
  DeviceSet& devices() { return devices_; }
  OperationRegistry& operations() { return operations_; }
  EventBus& events() { return events_; }
  session::SessionStore& store() { return store_; }
  // The cameras' latest frames for the live view (preview_hub.hpp).
  PreviewHub& previews() { return previews_; }

  // The live view's white balance of `camera` (white_balance.hpp): from the
  // library the estimator uses (light_sources()) and the camera's
  // sensitivity, under the LED controller's present drive; "none: raw" with
  // the reason when chromod has no measured library or the LEDs are off.
  WhiteBalance preview_white_balance(const std::string& camera);

  std::vector<DeviceReport> probe_devices();
  // What the lab's checks look at (lab_checks.hpp): every device probed now,
  // each camera's configured stream and the interface reaching it, the host
  // (net.core.rmem_max, free disk at sessions_dir, the clock), the LED
  // library's age, one standard session's bytes. Changes nothing.
  LabFacts lab_facts();
  // run_lab_checks on lab_facts(): chromo doctor, and the preflight before a session.
  std::vector<CheckResult> check_lab(const CheckLimits& limits = {});
  // Validated plan; throws std::invalid_argument (naming the field),
  // std::logic_error (another operation runs), std::runtime_error (devices).
  // The session's provenance (session_provenance(), with `people`) goes into
  // its session.json and its report.
  session::OperationRecord start_session(session::SessionPlan plan, const std::string& subject,
                                         const SessionPeople& people = {});
  // Whether a session of `plan` could start on this sphere now (the checks
  // start_session makes before anything runs: the plan's fields, its mixes'
  // weights, the blue-light hazard limit, an LED controller and a camera,
  // polariser banks for polarised steps, the controller's sequence capacity
  // for hardware timing). Returns when it could; throws what start_session
  // throws for them. Drives nothing.
  void check_plan_runs_here(const session::SessionPlan& plan);
  // What a session of `plan` started now would be made with: the LED library
  // that lights its illuminants and its age, each mix's drive levels and
  // origin, camera sensitivities, white target, the estimator's version and
  // options (session/session_provenance.hpp). Throws as resolve_mix.
  session::SessionProvenance session_provenance(const session::SessionPlan& plan, const SessionPeople& people) const;
  // A named mix's weights: solved on the calibrated library of `state` (a
  // sphere with banks keeps one per state), else the configured mixes.
  drivers::DriveLevels resolve_mix(const std::string& mix,
                                   drivers::Polarisation state = drivers::Polarisation::kUnpolarised) const;
  // The plan's blue-light hazard dose for the subject's eyes (session/plan_hazard.hpp)
  // with the daemon's LED library and `hazard` configuration; exposures of
  // metered steps when known. start_session refuses a plan beyond the limit
  // (std::invalid_argument naming the plan, the dose and the limit).
  session::PlanHazard plan_hazard(const session::SessionPlan& plan,
                                  const std::map<std::string, double>& exposure_us_of_step = {}) const;
  // The standard plan as the configuration's `capture` keys make it (exposure
  // per capture, white share, frames, blue ratio, polarised), before the
  // request's own choices. capture.polarised_plan "auto": polarised when the
  // LED controller reports polariser banks on every LED type
  // (polarised_plan_by_default), "on"/"off" forced.
  session::StandardPlanOptions standard_plan_options() const;
  // Whether the open LED controller reports polariser banks on all six LED
  // types (false without a controller or with some types unpolarised).
  bool controller_polarised_everywhere() const;
  // A calibration run (calibrations.hpp); same errors as start_session.
  session::OperationRecord start_calibration(const CalibrationRequest& request);
  // Calibrations::adopt once nothing runs (std::logic_error while an operation runs).
  std::string adopt_calibration(const std::string& id, const std::string& reason);
  Calibrations& calibrations() { return *calibrations_; }
  // Session folder of an id known to the registry; nullopt when unknown.
  std::optional<session::SessionInfo> session(const std::string& id) const;
  // Throws std::logic_error while a session runs.
  void ensure_idle() const;

  struct DeletedSession {
    std::uint64_t files = 0, bytes = 0;
    std::vector<std::string> cache_entries;  // forward_/inverse_table_<key>.bin no other session's results name
  };
  // Deletes a finished session's folder and the cache entries only it used.
  // Throws std::invalid_argument (unknown id), std::logic_error (it runs).
  DeletedSession delete_session(const std::string& id);

 private:
  // A mix's weights from the configuration's mixes (the daemon without a library).
  drivers::DriveLevels configured_mix(const std::string& mix) const;
  // The work of a session operation: the sequencer, the pipeline, derived
  // data and the on-line estimator's results, and the journal's last records.
  // What a running session records: its journal, and the latest blue-light
  // hazard record kept typed for the estimator's report.
  struct SessionRecords {
    std::shared_ptr<session::Journal> journal;
    std::shared_ptr<session::HazardRecord> hazard;
  };
  OperationRunner::Outcome run_session(RunningOperation& running, const session::SessionPlan& plan,
                                       const session::SessionProvenance& provenance, const SessionRecords& records,
                                       const std::filesystem::path& folder);

  // The sequencer's context for one session (daemon.cpp).
  SequencerContext sequencer_context(RunningOperation& running, const session::SessionPlan& plan,
                                     const SessionRecords& records, FramePipeline& pipeline);

  // The LED library and camera sensitivity the estimator would use (resolve_capture_sources).
  session::CaptureSources light_sources() const;

  DaemonConfig config_;
  DeviceSet devices_;
  FrameConsumer* estimator_;
  files::StorageBudget budget_;
  std::unique_ptr<FrameConsumer> owned_estimator_;
  EventBus events_;
  OperationRegistry operations_{events_};
  PreviewHub previews_{devices_, [this] { return operations_.any_active(); }};
  session::SessionStore store_;
  mutable session::SessionReadCache session_reads_;  // session(): a long journal is not re-read while unchanged
  // Runs sessions and calibrations; ~Daemon() stops it first, since the work
  // uses the members around it.
  OperationRunner runner_{operations_};
  std::unique_ptr<Calibrations> calibrations_;
  std::mutex delete_mutex_;
  TableCacheReferences table_references_;  // under delete_mutex_
};

}  // namespace chromo::daemon
