#pragma once
// Daemon: everything chromod runs, without the network. The gRPC service
// (service.hpp) is a thin translation of the API onto these calls, and tests
// can drive a Daemon directly.
//
// Owns the devices, the operation registry and event bus, the session store.
// One session or calibration runs at a time (on its own thread); starting a
// second gets FAILED_PRECONDITION from the API (std::logic_error here).
//
// Lifetime: the destructor cancels a running session and joins its thread;
// the session then ends CANCELLED on disk. Thread-safe.

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "chromo/daemon/calibrations.hpp"
#include "chromo/daemon/config.hpp"
#include "chromo/daemon/device_set.hpp"
#include "chromo/files/durable_file.hpp"
#include "chromo/daemon/operations.hpp"
#include "chromo/session/session_store.hpp"

namespace chromo::daemon {

struct DeviceReport {
  std::string name, backend, address;
  DeviceKind kind;
  enum class Health { kOk, kUnreachable, kFault } health = Health::kOk;
  std::string detail;
  std::map<std::string, std::string> info;
};

// Supplies the LED state of a named mix (the mix solver on the daemon's LED
// library when it has one; the configuration's "mixes" otherwise).
using MixResolver = std::function<drivers::DriveLevels(const std::string& mix)>;

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

  std::vector<DeviceReport> probe_devices();
  // Validated plan; throws std::invalid_argument (naming the field),
  // std::logic_error (another operation runs), std::runtime_error (devices).
  session::OperationRecord start_session(session::SessionPlan plan, const std::string& subject);
  drivers::DriveLevels resolve_mix(const std::string& mix) const;
  // A calibration run (calibrations.hpp); same errors as start_session.
  session::OperationRecord start_calibration(const CalibrationRequest& request);
  Calibrations& calibrations() { return *calibrations_; }
  // Session folder of an id known to the registry; nullopt when unknown.
  std::optional<session::SessionInfo> session(const std::string& id) const;
  // Throws std::logic_error while a session runs.
  void ensure_idle() const;

 private:
  void run_session(std::string id, session::SessionPlan plan, std::shared_ptr<session::Journal> journal, std::filesystem::path folder,
                   std::shared_ptr<OperationControl> control);

  DaemonConfig config_;
  DeviceSet devices_;
  FrameConsumer* estimator_;
  files::StorageBudget budget_;
  std::unique_ptr<FrameConsumer> owned_estimator_;
  EventBus events_;
  OperationRegistry operations_{events_};
  session::SessionStore store_;
  std::mutex run_mutex_;
  std::thread worker_;
  std::string running_id_;
  // Last: its destructor joins a running calibration, which uses the members above.
  std::unique_ptr<Calibrations> calibrations_;
};

}  // namespace chromo::daemon
