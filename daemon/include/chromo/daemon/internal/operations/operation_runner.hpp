#pragma once
// OperationRunner: the one way the daemon runs long work (a session, a
// calibration run) as an observable operation (operations.hpp).
//
// One operation at a time. start() checks that no operation in the registry
// is still running, lets the caller prepare (create its folder, write its
// first record) under the runner's lock, registers the operation's record
// and runs its work on a thread of its own. The work sees a RunningOperation:
// its id, its OperationControl (cancel and pause requests), record updates,
// and a files::Progress that writes the fraction, the time left and the step
// into the record and polls the cancel request. The work returns an Outcome;
// the runner writes it as the record's final update:
//
//   state      the Outcome's state (SUCCEEDED, CANCELLED, FAILED, ...);
//   error      the Outcome's error; a work that throws ends FAILED with the
//              exception's what() as its error;
//   message    the Outcome's message, or "done" when SUCCEEDED and the
//              state's name otherwise;
//   progress   1 when SUCCEEDED (else as last reported); eta_seconds 0;
//   counters   the Outcome's counters, when it has some (sessions).
//
// Nothing runs on the work's thread after that final update, so a start()
// that sees the operation final may join the thread at once.
//
// Thread rules: start() and cancel_and_join() are thread-safe. The work runs
// on its own thread; RunningOperation is for that thread (its progress may be
// handed to the work's helper threads under files::Progress's rules). The
// destructor is cancel_and_join(): whatever the work uses must outlive the
// runner, or its owner calls cancel_and_join() first (Daemon does).

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "chromo/daemon/internal/operations/operations.hpp"
#include "chromo/files/progress.hpp"
#include "chromo/session/operation_record.hpp"

namespace chromo::daemon {

// The one ETA of an operation: the time left when `fraction` of the work
// took `elapsed_s`, extrapolated linearly (elapsed·(1−f)/f); -1 (unknown)
// while nothing is done. Sessions' captures and the runner's work use it.
double remaining_seconds(double fraction, double elapsed_s);

// What the work of an operation sees while it runs.
class RunningOperation {
 public:
  RunningOperation(std::string id, OperationRegistry& operations, std::shared_ptr<OperationControl> control);

  const std::string& id() const { return id_; }
  OperationControl& control() { return *control_; }
  // Applies `change` to the operation's record (and publishes it).
  void update(const std::function<void(session::OperationRecord&)>& change);
  // report(f, step): record.progress = f, record.message = step, and
  // record.eta_seconds from the time since the work started (-1 at f = 0).
  // cancelled(): the operation's cancel request.
  files::Progress progress();

 private:
  std::string id_;
  OperationRegistry& operations_;
  std::shared_ptr<OperationControl> control_;
  std::chrono::steady_clock::time_point started_;
};

class OperationRunner {
 public:
  struct Outcome {
    session::OperationState state = session::OperationState::kFailed;
    std::string error;                    // what failed (FAILED)
    std::optional<std::string> message;   // the final message; default: "done" or the state's name
    std::optional<session::PipelineCounters> counters;
  };
  using Work = std::function<Outcome(RunningOperation&)>;
  // What a start()'s preparation hands over: the record to register (its id
  // new to the registry, its state PENDING or RUNNING) and the work to run.
  struct Start {
    session::OperationRecord record;
    Work work;
  };

  explicit OperationRunner(OperationRegistry& operations) : operations_(operations) {}
  ~OperationRunner() { cancel_and_join(); }
  OperationRunner(const OperationRunner&) = delete;
  OperationRunner& operator=(const OperationRunner&) = delete;

  // Throws std::logic_error("another session or calibration is running")
  // while any operation in the registry is not final. Otherwise calls
  // prepare() under the runner's lock (what it throws propagates and nothing
  // starts), registers its record, starts its work on a new thread and
  // returns the record as registered.
  session::OperationRecord start(const std::function<Start()>& prepare);

  // Requests cancellation of the operation started last (no-op once it is
  // final) and waits for its thread.
  void cancel_and_join();

 private:
  void run(RunningOperation& running, const Work& work);

  OperationRegistry& operations_;
  std::mutex mutex_;  // worker_, control_
  std::thread worker_;
  std::shared_ptr<OperationControl> control_;
};

}  // namespace chromo::daemon
