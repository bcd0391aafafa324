#include "chromo/daemon/internal/operations/operation_runner.hpp"

#include <stdexcept>

namespace chromo::daemon {

double remaining_seconds(double fraction, double elapsed_s) {
  return fraction > 0 ? elapsed_s * (1 - fraction) / fraction : -1;
}

RunningOperation::RunningOperation(std::string id, OperationRegistry& operations, std::shared_ptr<OperationControl> control)
    : id_(std::move(id)), operations_(operations), control_(std::move(control)), started_(std::chrono::steady_clock::now()) {}

void RunningOperation::update(const std::function<void(session::OperationRecord&)>& change) { operations_.update(id_, change); }

files::Progress RunningOperation::progress() {
  files::Progress progress;
  progress.on_progress = [this](double fraction, const std::string& step) {
    const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    update([&](session::OperationRecord& r) {
      r.progress = fraction;
      r.eta_seconds = remaining_seconds(fraction, elapsed_s);
      r.message = step;
    });
  };
  progress.should_cancel = [control = control_] { return control->cancel_requested(); };
  return progress;
}

session::OperationRecord OperationRunner::start(const std::function<Start()>& prepare) {
  std::lock_guard lock(mutex_);
  if (operations_.any_active()) throw std::logic_error("another session or calibration is running");
  // The operation before has finished: its thread ends right after its final update.
  if (worker_.joinable()) worker_.join();
  Start start = prepare();
  const std::string id = start.record.id;
  control_ = operations_.add(std::move(start.record));
  worker_ = std::thread([this, id, control = control_, work = std::move(start.work)] {
    RunningOperation running(id, operations_, control);
    run(running, work);
  });
  auto started = operations_.get(id);
  if (!started) throw std::runtime_error("operation " + id + " vanished from the registry");
  return *started;
}

void OperationRunner::run(RunningOperation& running, const Work& work) {
  Outcome outcome;
  try {
    outcome = work(running);
  } catch (const std::exception& error) {
    outcome = {session::OperationState::kFailed, error.what(), std::nullopt, std::nullopt};
  }
  // The final update: nothing on this thread may follow it (start() joins
  // the thread as soon as it sees the record final).
  running.update([&](session::OperationRecord& r) {
    r.state = outcome.state;
    r.error = outcome.error;
    r.message = outcome.message ? *outcome.message
                                : outcome.state == session::OperationState::kSucceeded ? std::string("done")
                                                                                         : session::state_name(outcome.state);
    if (outcome.counters) r.counters = *outcome.counters;
    if (outcome.state == session::OperationState::kSucceeded) r.progress = 1;
    r.eta_seconds = 0;
  });
}

void OperationRunner::cancel_and_join() {
  std::thread worker;
  {
    std::lock_guard lock(mutex_);
    if (control_) control_->request_cancel();
    worker = std::move(worker_);
  }
  if (worker.joinable()) worker.join();
}

}  // namespace chromo::daemon
