#pragma once
// Calibrations: the daemon's LED library, its calibration runs (the
// calibration library's CalibrationRun on the configured LED controller and
// spectrometer) and the mix solver on that library (calibration::solve_mix,
// the same solver as `chromo leds solve`).
//
// A calibration run is an observable operation (kind kCalibration) like a
// session, run by the daemon's OperationRunner (operation_runner.hpp):
// start() returns at once with its id; the run reports progress
// (0-1), the estimated time left and the step being measured; cancel is
// honoured between measurements. Its folder is
//
//   <sessions_dir>/calibrations/<id>/calibration.json   request, state, summary (crash-safe rewrite)
//                                    led-library.json   the measured library (docs/formats/led-library.md)
//                                    led-library-cross.json, led-library-parallel.json
//                                                       on a sphere with polariser banks on every LED type:
//                                                       one run per state, one library per state
//
// calibration.json is written when the run starts (state "running") and when
// it ends (final state and summary); recover() reads every folder back at
// start-up, so a finished run is fetched by id after a restart and one that
// was in flight is reported INTERRUPTED (and rewritten so). The newest
// SUCCEEDED run's library is the daemon's LED library; without one the
// configured `led_library` file (docs/config.md), if any.
//
// Mixes: with a library, solved_mix() solves d65 / w57 / w57+blue[:R]
// (camera objective, the Nikon D5100 sensitivity, as `chromo leds solve`'s
// defaults) and caches the weights until the library changes.
//
// Adoption (issue 40): before an unpolarised run's library replaces the one
// in use, both libraries' session mixes (AdoptionCheck::mixes) are driven on
// the LEDs and measured (calibration::compare_libraries_on_leds, with the new
// run's spectrometer response); a library worse than the one in use on any
// figure is kept in its folder, its run SUCCEEDED with "adopted": false and
// the figures in calibration.json, and the daemon keeps its library until an
// operator adopts it explicitly (adopt(), with a reason the API audits).
// "The one in use" without a library is the configured mixes
// (AdoptionCheck::configured_mix) predicted by the nominal built-in library.
//
// Polarisation states (docs/polarisation.md "Calibration per state"): when
// the controller reports banks on every LED type, a calibration measures the
// cross state, then the parallel state (progress in two halves, each step
// named by its state). Both libraries are written and adopted only when both
// runs succeeded; a failed second run leaves the first state's library in
// the run's folder but the daemon keeps the libraries it had. solved_mix
// for a cross or parallel step solves on that state's library, falling back
// to the unpolarised one when the state has none.
//
// Thread rules: thread-safe. The runner must stop (cancel and join) before
// the Calibrations is destroyed (Daemon does). The devices' mutexes are held
// per call, not for the whole run (status queries stay answered).

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "chromo/calibration/library_check.hpp"
#include "chromo/calibration/session_mix.hpp"
#include "chromo/daemon/internal/devices/device_set.hpp"
#include "chromo/files/durable_file.hpp"
#include "chromo/daemon/internal/operations/operation_runner.hpp"
#include "chromo/daemon/internal/operations/operations.hpp"
#include "chromo/session/session_captures.hpp"

namespace chromo::calibration {
struct LedLibrary;
}

namespace chromo::daemon {

struct CalibrationRequest {
  std::string controller;             // empty: the only one
  std::string spectrometer;           // empty: the only one
  std::vector<double> drive_levels;   // strictly increasing, each in (0, 1]; empty: 0.25 0.5 0.75 1
  // Wall-clock warm-up per LED type, at most 600000; 0: the default, 2 s on
  // real devices, 300 s of LED time on the virtual lab (1 s at 300x).
  // Settling after each drive change: 0.2 s, or 30 s of LED time on the lab.
  std::uint32_t warmup_ms = 0;
};

// What a new library is checked on before it is adopted.
struct AdoptionCheck {
  std::vector<std::string> mixes{"d65", "w57+blue", "w57"};  // the standard plan's
  // The weights the daemon drives for a mix while it has no library (its configured mixes).
  std::function<drivers::DriveLevels(const std::string& mix)> configured_mix;
};

class Calibrations {
 public:
  // root: <sessions_dir>/calibrations (created by the first run). configured_library: the
  // configuration's led_library (may be empty).
  Calibrations(std::filesystem::path root, std::filesystem::path configured_library, DeviceSet& devices,
               OperationRunner& runner, files::StorageBudget* budget, AdoptionCheck adoption = {});
  // Adopts the library of a succeeded run that was not adopted (worse than
  // the one in use then) as the daemon's: calibration.json records
  // "adopted": true and the reason. std::invalid_argument naming "id" for an
  // unknown run, "reason" when empty; std::logic_error for a run that did not
  // succeed or has no library. Returns the adopted library's path.
  std::string adopt(const std::string& id, const std::string& reason);

  // Every run in the folder, in-flight ones marked interrupted on disk; also
  // loads the newest succeeded run's library.
  std::vector<session::OperationRecord> recover();

  // Validates (std::invalid_argument naming the field; std::logic_error when
  // a device is not open or there is no reference lamp; std::logic_error
  // from the runner while another operation runs), writes the folder, starts
  // the run on the runner.
  session::OperationRecord start(const CalibrationRequest& request);

  // std::invalid_argument naming "target"/"objective" for a bad request;
  // std::logic_error (FAILED_PRECONDITION) when there is no library.
  calibration::SolvedMix solve(const std::string& target, const std::string& objective, bool hold_chromaticity) const;
  // The weights of a session mix from the library; nullopt without a library.
  std::optional<drivers::DriveLevels> solved_mix(
      const std::string& mix, drivers::Polarisation state = drivers::Polarisation::kUnpolarised) const;
  // The library a step in `state` is lit by: that state's measured library,
  // else the unpolarised one (null when none).
  std::shared_ptr<const calibration::LedLibrary> library_for(drivers::Polarisation state) const;
  // The measured library of each polarisation state that has one (kCross,
  // kParallel), with its file: the illuminants of a session's frames lit in
  // that state (session::CaptureSources::led_library_of_state).
  std::map<drivers::Polarisation, session::StateLedLibrary> measured_state_libraries() const;
  // The library file in use ("" when none).
  std::string library_path() const;
  // The library in use (null when none): the plan advisor predicts from it.
  std::shared_ptr<const calibration::LedLibrary> library() const;

 private:
  // The work of a calibration operation: the run, then the library and the
  // final calibration.json.
  OperationRunner::Outcome run(RunningOperation& running, const CalibrationRequest& request,
                               const std::filesystem::path& folder, NamedDevice<drivers::LedController>* led,
                               NamedDevice<drivers::Spectrometer>* spectrometer);
  void use_library(const std::filesystem::path& path,
                   drivers::Polarisation state = drivers::Polarisation::kUnpolarised);
  // The state's slot in the maps below: the library a step in `state` is lit by.
  drivers::Polarisation library_state(drivers::Polarisation state) const;

  // The check of a new library against the one in use (null: adopted as before).
  std::optional<calibration::LibraryComparison> check_adoption(const calibration::LedLibrary& candidate,
                                                               NamedDevice<drivers::LedController>* led,
                                                               NamedDevice<drivers::Spectrometer>* spectrometer);

  std::filesystem::path root_;
  AdoptionCheck adoption_;
  DeviceSet& devices_;
  OperationRunner& runner_;
  files::StorageBudget* budget_;

  mutable std::mutex mutex_;  // library, cache
  std::shared_ptr<const calibration::LedLibrary> library_;  // unpolarised
  std::filesystem::path library_path_;
  // The measured libraries of a sphere with banks: kCross, kParallel.
  std::map<drivers::Polarisation, std::shared_ptr<const calibration::LedLibrary>> state_libraries_;
  std::map<drivers::Polarisation, std::filesystem::path> state_library_paths_;
  mutable std::map<std::pair<std::string, drivers::Polarisation>, drivers::DriveLevels> mix_cache_;
};

}  // namespace chromo::daemon
