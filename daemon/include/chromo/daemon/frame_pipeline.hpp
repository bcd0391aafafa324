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
// renamed into place and its journal entry is fsynced.
//
// The estimator may fall behind: a frame offered to a full estimator queue is
// counted as skipped with reason "queue_full" (the estimator reads it back
// from storage later); without an estimator, every frame is skipped with
// reason "no_estimator".
//
// When storage fails (disk or budget full), the pipeline stops storing:
// storage_error() is set, further frames are refused (counted lost with reason
// "storage_stopped"), and nothing already stored is touched.
//
// Thread rules: submit() and record_lost() from any thread; drain() and the
// destructor from the owner's thread. Counters are atomic snapshots.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "chromo/daemon/journal.hpp"
#include "chromo/drivers/camera.hpp"

namespace chromo::daemon {

struct CapturedFrame {
  std::string camera;
  std::string step;
  int step_index = 0;
  drivers::Frame frame;
  nlohmann::json metadata;  // LED state and temperatures, exposure, ...: goes into the journal entry
  std::chrono::steady_clock::time_point trigger_time;
};

struct StoredFrame {
  std::uint64_t index;          // session-wide storage order
  std::string file;             // relative to the session folder
  const CapturedFrame* frame;
};

struct PipelineCounters {
  std::uint64_t received = 0, stored = 0, estimated = 0, estimator_skipped = 0, lost = 0, resent_packets = 0;
  std::map<std::string, std::uint64_t> lost_reasons, skipped_reasons;
  double max_trigger_to_stored_ms = 0, mean_trigger_to_stored_ms = 0;
  double storage_cpu_ms = 0, estimator_cpu_ms = 0;  // CPU time of the pipeline's own threads
};

// The on-line estimator's side of the pipeline (estimation plugs in here).
class FrameConsumer {
 public:
  virtual ~FrameConsumer() = default;
  // Called on the estimator thread, one frame at a time.
  virtual void consume(const CapturedFrame& frame, const StoredFrame& stored) = 0;
};

class FramePipeline {
 public:
  struct Options {
    std::size_t storage_queue_frames = 64;
    std::size_t estimator_queue_frames = 8;
  };
  FramePipeline(std::filesystem::path folder, Journal& journal, StorageBudget* budget, Options options,
                FrameConsumer* estimator, std::function<void(const StoredFrame&)> on_stored);
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
  PipelineCounters counters() const;
  // Empty while storage works; the reason storage stopped otherwise.
  std::string storage_error() const;

 private:
  void storage_loop();
  void estimator_loop();

  std::filesystem::path folder_;
  Journal& journal_;
  StorageBudget* budget_;
  Options options_;
  FrameConsumer* estimator_;
  std::function<void(const StoredFrame&)> on_stored_;

  mutable std::mutex mutex_;
  std::condition_variable storage_wake_, space_free_, idle_, estimator_wake_;
  std::deque<CapturedFrame> storage_queue_;
  std::deque<std::pair<CapturedFrame, StoredFrame>> estimator_queue_;
  bool storing_ = false, estimating_ = false, stopping_ = false;
  std::string storage_error_;
  PipelineCounters counters_;
  double latency_sum_ms_ = 0;
  std::uint64_t next_index_ = 0;
  std::thread storage_thread_, estimator_thread_;
};

}  // namespace chromo::daemon
