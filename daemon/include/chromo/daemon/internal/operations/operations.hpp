#pragma once
// Operations: long work (sessions, calibration runs) as observable records,
// and the daemon's event bus.
//
// A session::OperationRecord (session/operation_record.hpp) is the API's Operation in C++ form. OperationRegistry
// holds every operation this daemon knows: the ones it runs and the ones
// read back from the sessions folder at start-up (finished, or INTERRUPTED
// when they were in flight at the restart). Each update bumps a version and
// wakes watchers; every update is also published as an event.
//
// OperationControl is what a running operation polls: cancel and pause
// requests. Meanings (also in operations.proto):
//  - pause: the step in progress finishes, then the sequencer waits before
//    the next step; the operation is PAUSED. The daemon pauses by itself when
//    a device stops answering (message says which) or a step has a prompt.
//  - resume: continue with the next step (or retry the one a device failure
//    interrupted).
//  - cancel: abandon the step in progress at the next frame boundary; frames
//    already stored stay stored; the LEDs are switched off; CANCELLED.
//
// Thread rules: everything is thread-safe.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "chromo/session/operation_record.hpp"

namespace chromo::daemon {

class OperationControl {
 public:
  void request_cancel();
  void request_pause();
  void request_resume();
  bool cancel_requested() const;
  bool pause_requested() const;
  // Blocks while paused; returns false when cancelled (meanwhile or before).
  bool wait_while_paused();
  // Sleeps up to `duration`; returns false early when cancelled.
  bool sleep_unless_cancelled(std::chrono::milliseconds duration);
  // The daemon pauses itself (device stopped answering, prompt).
  void pause_by_daemon();

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool cancel_ = false, pause_ = false;
};

struct Event {
  std::uint64_t sequence = 0;
  std::chrono::system_clock::time_point time;
  enum class Kind { kOperation, kLog, kFrame } kind = Kind::kLog;
  session::OperationRecord operation;  // kOperation
  std::string log;            // kLog
  std::string session_id, step, camera;  // kFrame
  std::uint64_t frame_index = 0;
};

// Fan-out of events to subscribers, each with a bounded backlog.
class EventBus {
 public:
  static constexpr std::size_t kBacklog = 1024;
  class Subscription {
   public:
    // Waits up to `timeout` for events; returns those queued (maybe none) and
    // how many were dropped because the subscriber read too slowly.
    std::vector<Event> next(std::chrono::milliseconds timeout, std::uint64_t* dropped);

   private:
    friend class EventBus;
    std::mutex mutex_;
    std::condition_variable ready_;
    std::deque<Event> queue_;
    std::uint64_t dropped_ = 0;
    bool include_frames_ = false;
  };
  std::shared_ptr<Subscription> subscribe(bool include_frames);
  void publish(Event event);

 private:
  std::mutex mutex_;
  std::uint64_t sequence_ = 0;
  std::vector<std::weak_ptr<Subscription>> subscribers_;
};

class OperationRegistry {
 public:
  explicit OperationRegistry(EventBus& events) : events_(events) {}
  // Adds a record (id must be new) with its control.
  std::shared_ptr<OperationControl> add(session::OperationRecord record);
  // Adds a finished record read from disk (no control).
  void add_past(session::OperationRecord record);
  // Forgets an operation (a deleted session).
  void remove(const std::string& id);
  // Applies `change` to the record and publishes it; no-op for unknown ids.
  void update(const std::string& id, const std::function<void(session::OperationRecord&)>& change);
  std::optional<session::OperationRecord> get(const std::string& id) const;
  std::shared_ptr<OperationControl> control(const std::string& id) const;
  std::vector<session::OperationRecord> list() const;  // newest first
  // Waits until the record's version exceeds `seen_version` or the timeout
  // passes; returns the record and its version.
  std::optional<std::pair<session::OperationRecord, std::uint64_t>> wait_change(const std::string& id, std::uint64_t seen_version,
                                                                       std::chrono::milliseconds timeout) const;
  // True while some operation is not final.
  bool any_active() const;

 private:
  struct Entry {
    session::OperationRecord record;
    std::shared_ptr<OperationControl> control;
    std::uint64_t version = 1;
  };
  EventBus& events_;
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::map<std::string, Entry> entries_;
};

}  // namespace chromo::daemon
