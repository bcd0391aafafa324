// The OperationRunner's contract (daemon/internal/operations/operation_runner.hpp) on a bare
// registry, without devices: progress reaches the record, a cancelled work
// ends CANCELLED with its message, a throwing one FAILED naming the error,
// one operation at a time, and the destructor cancels and joins.

#include "chromo/daemon/internal/operations/operation_runner.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>

namespace chromo::daemon {
namespace {

using session::OperationRecord;
using session::OperationState;
using namespace std::chrono_literals;

OperationRunner::Start start_of(const std::string& id, OperationRunner::Work work) {
  OperationRecord record;
  record.id = id;
  record.kind = session::OperationKind::kCalibration;
  record.name = "test";
  record.state = OperationState::kRunning;
  return {record, std::move(work)};
}

// Waits (up to 10 s) until the record satisfies `done`; fails the test otherwise.
template <typename Predicate>
OperationRecord wait_until(const OperationRegistry& registry, const std::string& id, Predicate done) {
  std::uint64_t version = 0;
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < deadline) {
    auto change = registry.wait_change(id, version, 100ms);
    if (!change) break;
    if (done(change->first)) return change->first;
    version = change->second;
  }
  ADD_FAILURE() << "operation " << id << " never reached the expected record";
  return registry.get(id).value_or(OperationRecord{});
}

struct Registry {
  EventBus events;
  OperationRegistry operations{events};
};

TEST(OperationRunner, ProgressReachesTheRecordAndACancelledWorkEndsCancelledWithItsMessage) {
  Registry r;
  OperationRunner runner(r.operations);
  std::atomic<int> polls_after_report{0};
  auto started = runner.start([] {
    return start_of("op-cancel", [](RunningOperation& running) -> OperationRunner::Outcome {
      const files::Progress progress = running.progress();
      std::this_thread::sleep_for(20ms);  // some time passes: a finite time left
      progress.report(0.25, "measuring red");
      while (!progress.cancelled()) std::this_thread::sleep_for(1ms);
      return {OperationState::kCancelled, "", "cancelled while measuring red", std::nullopt};
    });
  });
  EXPECT_EQ(started.id, "op-cancel");
  EXPECT_EQ(started.state, OperationState::kRunning);

  const auto midway = wait_until(r.operations, "op-cancel", [](const OperationRecord& o) { return o.progress == 0.25; });
  EXPECT_EQ(midway.message, "measuring red");
  EXPECT_GT(midway.eta_seconds, 0.0);  // 3 × the elapsed time
  EXPECT_EQ(midway.state, OperationState::kRunning);

  r.operations.control("op-cancel")->request_cancel();
  const auto final = wait_until(r.operations, "op-cancel", [](const OperationRecord& o) { return session::is_final(o.state); });
  EXPECT_EQ(final.state, OperationState::kCancelled);
  EXPECT_EQ(final.message, "cancelled while measuring red");
  EXPECT_EQ(final.error, "");
  EXPECT_DOUBLE_EQ(final.progress, 0.25);  // 1 only when it succeeds
  EXPECT_DOUBLE_EQ(final.eta_seconds, 0.0);
}

TEST(OperationRunner, AThrowingWorkEndsFailedNamingTheError) {
  Registry r;
  OperationRunner runner(r.operations);
  runner.start([] {
    return start_of("op-fail", [](RunningOperation&) -> OperationRunner::Outcome {
      throw std::runtime_error("spectrometer \"usb0\": read_raw_spectrum timed out");
    });
  });
  const auto final = wait_until(r.operations, "op-fail", [](const OperationRecord& o) { return session::is_final(o.state); });
  EXPECT_EQ(final.state, OperationState::kFailed);
  EXPECT_EQ(final.error, "spectrometer \"usb0\": read_raw_spectrum timed out");
  EXPECT_EQ(final.message, "failed");  // the state's name when the work gave no message
}

TEST(OperationRunner, ASucceededWorkEndsDoneAtOneWithItsCounters) {
  Registry r;
  OperationRunner runner(r.operations);
  runner.start([] {
    return start_of("op-ok", [](RunningOperation& running) -> OperationRunner::Outcome {
      running.progress().report(0.5, "half");
      session::PipelineCounters counters;
      counters.stored = 42;
      return {OperationState::kSucceeded, "", std::nullopt, counters};
    });
  });
  const auto final = wait_until(r.operations, "op-ok", [](const OperationRecord& o) { return session::is_final(o.state); });
  EXPECT_EQ(final.state, OperationState::kSucceeded);
  EXPECT_EQ(final.message, "done");
  EXPECT_DOUBLE_EQ(final.progress, 1.0);
  EXPECT_EQ(final.counters.stored, 42u);
}

TEST(OperationRunner, OneAtATimeAndAFailedPreparationStartsNothing) {
  Registry r;
  OperationRunner runner(r.operations);
  std::atomic<bool> release{false};
  runner.start([&] {
    return start_of("op-first", [&](RunningOperation&) -> OperationRunner::Outcome {
      while (!release) std::this_thread::sleep_for(1ms);
      return {OperationState::kSucceeded, "", std::nullopt, std::nullopt};
    });
  });
  bool prepared = false;
  try {
    runner.start([&] {
      prepared = true;
      return start_of("op-second", [](RunningOperation&) { return OperationRunner::Outcome{}; });
    });
    ADD_FAILURE() << "a second operation started while the first runs";
  } catch (const std::logic_error& busy) {
    EXPECT_STREQ(busy.what(), "another session or calibration is running");
  }
  EXPECT_FALSE(prepared);  // the folder of a refused start is never made
  EXPECT_FALSE(r.operations.get("op-second"));

  release = true;
  wait_until(r.operations, "op-first", [](const OperationRecord& o) { return session::is_final(o.state); });
  EXPECT_THROW(runner.start([]() -> OperationRunner::Start { throw std::invalid_argument("plan.steps: empty"); }),
               std::invalid_argument);
  EXPECT_EQ(r.operations.list().size(), 1u);
  // Free again: the next one starts (and joins the finished thread).
  runner.start([] {
    return start_of("op-third", [](RunningOperation&) {
      return OperationRunner::Outcome{OperationState::kSucceeded, "", std::nullopt, std::nullopt};
    });
  });
  EXPECT_EQ(wait_until(r.operations, "op-third", [](const OperationRecord& o) { return session::is_final(o.state); }).state,
            OperationState::kSucceeded);
}

TEST(OperationRunner, TheDestructorCancelsAndJoins) {
  Registry r;
  std::atomic<bool> saw_cancel{false};
  {
    OperationRunner runner(r.operations);
    runner.start([&] {
      return start_of("op-left", [&](RunningOperation& running) -> OperationRunner::Outcome {
        while (!running.control().cancel_requested()) std::this_thread::sleep_for(1ms);
        saw_cancel = true;
        return {OperationState::kCancelled, "", std::nullopt, std::nullopt};
      });
    });
  }
  EXPECT_TRUE(saw_cancel);
  const auto final = r.operations.get("op-left");
  ASSERT_TRUE(final);
  EXPECT_EQ(final->state, OperationState::kCancelled);
  EXPECT_EQ(final->message, "cancelled");
}

}  // namespace
}  // namespace chromo::daemon
