#pragma once
// FramePipeline: frames from the cameras to storage (and to the on-line
// estimator), through bounded queues with counters.
//
//   camera stream thread --submit()--> [storage queue] --storage thread--> TIFF + journal (fsync)
//                                                            \--> [estimator queue] --> FrameConsumer
//
// Storage never drops a frame: submit() blocks while the storage queue is
// full (the camera driver's own buffer pool then absorbs the burst, and what
// the link loses meanwhile is counted as lost with the driver's reason). A
// frame counts as stored, and is acknowledged (on_stored), once its TIFF is
// renamed into place and its journal entry is fsynced. The record becomes
// JSON only there (session::to_json, the journal's edge).
//
// The estimator may fall behind: a frame offered to a full estimator queue is
// counted as skipped with reason "queue_full" (the estimator reads it back
// from storage later, FrameConsumer::end_session) and on_estimator_behind is
// called (once per run of skipped frames, with the count so far); the
// counters show the queue's depth now and at most. Without an estimator,
// every frame is skipped with reason "no_estimator".
//
// When storage fails (disk or budget full), the pipeline stops storing:
// storage_error() is set, further frames are refused (counted lost with reason
// "storage_stopped"), and nothing already stored is touched.
//
// Thread rules: submit() and record_lost() from any thread; drain(), drain_storage() and the
// destructor from the owner's thread. Counters are atomic snapshots.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/session/frame_record.hpp"
#include "chromo/session/frame_sums.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/session/session_provenance.hpp"
#include "chromo/session/operation_record.hpp"
#include "chromo/session/plan_hazard.hpp"
#include "chromo/drivers/camera.hpp"
#include "chromo/files/progress.hpp"

namespace chromo::daemon {

// A complete frame on its way: the typed record (the sequencer fills
// everything but index and file, which storage sets) and the samples as the
// camera sent them (session::FrameRecord's geometry and pixel format).
struct CapturedFrame {
  session::FrameRecord record;
  std::vector<std::uint8_t> samples;
  std::chrono::steady_clock::time_point trigger_time;
};

struct StoredFrame {
  std::uint64_t index;          // session-wide storage order
  std::string file;             // relative to the session folder
  const CapturedFrame* frame;
};

// The on-line estimator's side of the pipeline (estimation plugs in here;
// daemon/internal/capture/online_estimator.hpp). One session at a time: the daemon calls
// begin_session() on the session's thread before the first frame, the
// pipeline calls consume() on its estimator thread for every stored frame
// that fits in the estimator queue, and the daemon calls end_session() on the
// session's thread once every frame is stored and the queue is drained.
class FrameConsumer {
 public:
  struct SessionStart {
    std::string id;
    std::filesystem::path folder;
    session::SessionPlan plan;  // the plan the sequencer runs (session.json's "plan")
    // Progress of the consumer's own work (0-1) with a short message; any thread.
    files::Progress progress;
    // The session's cameras (device names); empty: not known, the consumer
    // waits for the end of the session to know which delivered.
    std::vector<std::string> cameras;
    // What the session is made with (session.json's provenance); the report repeats it.
    session::SessionProvenance provenance;
    // The sums of the session's frames that the pipeline's storage thread
    // fills (FramePipeline::Options::stored_sums), every frame added before
    // consume() sees it; null: the consumer sums the samples itself.
    std::shared_ptr<const session::SessionFrameSums> stored_sums;
    // The session's latest blue-light hazard record (the planned one, then
    // the metered one), which its report repeats; null: none recorded.
    std::shared_ptr<const session::HazardRecord> blue_light_hazard;
  };
  struct SessionEnd {
    bool succeeded = false;  // the plan ran to its end (else results are not attempted)
  };
  virtual ~FrameConsumer() = default;
  virtual void begin_session(const SessionStart&) {}
  // Called on the estimator thread, one frame at a time.
  virtual void consume(const CapturedFrame& frame, const StoredFrame& stored) = 0;
  // Catches up on frames the queue skipped (from storage), finishes, and
  // returns the journal's "results" record (docs/formats/session.md; null: none).
  virtual nlohmann::json end_session(const SessionEnd&) { return nullptr; }
};

class FramePipeline {
 public:
  struct Options {
    std::size_t storage_queue_frames = 64;
    std::size_t estimator_queue_frames = 8;
    // Optional: every stored frame is added here by the storage thread, after
    // its journal record is fsynced (derived data is written from it). Owned
    // by the caller, who reads it only after drain_storage() (or drain()) and
    // keeps it alive until the pipeline is destroyed.
    session::SessionFrameSums* stored_sums = nullptr;
  };
  FramePipeline(std::filesystem::path folder, session::Journal& journal, files::StorageBudget* budget, Options options,
                FrameConsumer* estimator, std::function<void(const StoredFrame&)> on_stored,
                std::function<void(std::uint64_t skipped_so_far)> on_estimator_behind = {});
  ~FramePipeline();  // drains, then stops the threads
  FramePipeline(const FramePipeline&) = delete;
  FramePipeline& operator=(const FramePipeline&) = delete;

  // A complete frame. Blocks while the storage queue is full.
  void submit(CapturedFrame frame);
  // A frame the camera link lost (failure status, or never delivered).
  void record_lost(const std::string& reason);
  void add_resent_packets(std::uint64_t packets);
  // Waits until every submitted frame is stored (or storage failed) and the
  // estimator has consumed its queue.
  void drain();
  // Waits until every submitted frame is stored (or storage failed), whatever
  // the estimator is doing: a step is complete once its frames are safe, and
  // the next step's capture does not wait for the estimator (its tables are
  // prepared while the subject steps are captured).
  void drain_storage();
  session::PipelineCounters counters() const;
  // Empty while storage works; the reason storage stopped otherwise.
  std::string storage_error() const;
  // Empty unless Options::stored_sums refused a stored frame (its step's
  // frames differ in size or format); the first refusal otherwise.
  std::string stored_sums_error() const;

 private:
  void storage_loop();
  void estimator_loop();

  std::filesystem::path folder_;
  session::Journal& journal_;
  files::StorageBudget* budget_;
  Options options_;
  FrameConsumer* estimator_;
  std::function<void(const StoredFrame&)> on_stored_;
  std::function<void(std::uint64_t)> on_estimator_behind_;
  bool behind_ = false;  // the last frame offered to the estimator was skipped

  mutable std::mutex mutex_;
  std::condition_variable storage_wake_, space_free_, idle_, estimator_wake_;
  std::deque<CapturedFrame> storage_queue_;
  std::deque<std::pair<CapturedFrame, StoredFrame>> estimator_queue_;
  bool storing_ = false, estimating_ = false, stopping_ = false;
  std::string storage_error_;
  std::string stored_sums_error_;
  session::PipelineCounters counters_;
  double latency_sum_ms_ = 0;
  std::uint64_t next_index_ = 0;
  std::thread storage_thread_, estimator_thread_;
};

}  // namespace chromo::daemon
