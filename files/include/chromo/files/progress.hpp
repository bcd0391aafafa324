#pragma once
// Progress: the one way long work reports how far it is and learns that it
// should stop. Calibration runs (calibration/calibration_run.hpp,
// closed_loop.hpp), table builds (maps/profile_table.hpp), estimation
// (estimation/estimator.hpp) and sessions (the daemon's on-line estimator)
// all take one; the daemon's OperationRunner makes one per operation that
// writes into the operation's record and polls its cancel request.
//
// It lives in files/ because files/ is the one library every library that
// does long work already depends on, and it depends on nothing itself; the
// header needs nothing but the standard library.
//
// The contract, for the work (the callee) and for the caller:
//
//  - report(fraction, step): the work calls it at its checkpoints (a function
//    taking a Progress says which: between measurements, after each tile,
//    ...). `fraction` is the share of the whole work done so far, in [0, 1],
//    never decreasing from one call to the next; 1 is reported once the work
//    is complete (a cancelled or failed run may never report 1). `step` is a
//    short text for a person: what is being done now ("warming up red",
//    "estimating maps").
//  - cancelled(): the work polls it at its checkpoints. Once it returns true,
//    the work starts nothing new and returns at that checkpoint, reporting
//    the cancellation the way its own documentation says (a summary marked
//    cancelled, or a thrown files::Cancelled). Work already finished is kept
//    as that function documents. Callers make it stay true once it is true.
//  - Threads: both are called from the work's own thread(s), never
//    concurrently: work that runs on several threads serialises its calls.
//    The caller's callbacks must be thread-safe towards the caller's other
//    threads (the daemon's record updates are), return quickly and not call
//    back into the work.
//  - Either callback may be empty: no reports / never cancelled. A
//    default-constructed Progress does nothing.

#include <functional>
#include <stdexcept>
#include <string>

namespace chromo::files {

struct Progress {
  // Called by report(): the fraction done (0-1) and what is being done now.
  std::function<void(double fraction, const std::string& step)> on_progress;
  // Polled by cancelled(): true asks the work to stop at its next checkpoint.
  std::function<bool()> should_cancel;

  void report(double fraction, const std::string& step) const {
    if (on_progress) on_progress(fraction, step);
  }
  bool cancelled() const { return should_cancel && should_cancel(); }
};

// Thrown by work that takes a Progress and has no summary to mark cancelled
// (build_profile_table, for one) when cancelled() said so. what(): "cancelled".
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

}  // namespace chromo::files
