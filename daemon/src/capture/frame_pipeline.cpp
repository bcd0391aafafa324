#include "chromo/daemon/internal/capture/frame_pipeline.hpp"

#include <time.h>

#include <cstdio>

#include "chromo/session/frame_files.hpp"

namespace chromo::daemon {

namespace {
double thread_cpu_ms() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) * 1e3 + static_cast<double>(now.tv_nsec) * 1e-6;
}
}  // namespace

FramePipeline::FramePipeline(std::filesystem::path folder, session::Journal& journal, files::StorageBudget* budget, Options options,
                             FrameConsumer* estimator, std::function<void(const StoredFrame&)> on_stored,
                             std::function<void(std::uint64_t)> on_estimator_behind)
    : folder_(std::move(folder)),
      journal_(journal),
      budget_(budget),
      options_(options),
      estimator_(estimator),
      on_stored_(std::move(on_stored)),
      on_estimator_behind_(std::move(on_estimator_behind)) {
  storage_thread_ = std::thread([this] { storage_loop(); });
  if (estimator_) estimator_thread_ = std::thread([this] { estimator_loop(); });
}

FramePipeline::~FramePipeline() {
  drain();
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  storage_wake_.notify_all();
  estimator_wake_.notify_all();
  storage_thread_.join();
  if (estimator_thread_.joinable()) estimator_thread_.join();
}

void FramePipeline::submit(CapturedFrame frame) {
  std::unique_lock lock(mutex_);
  if (!storage_error_.empty()) {
    ++counters_.lost;
    ++counters_.lost_reasons["storage_stopped"];
    return;
  }
  ++counters_.received;
  space_free_.wait(lock, [&] { return storage_queue_.size() < options_.storage_queue_frames || !storage_error_.empty(); });
  if (!storage_error_.empty()) {
    ++counters_.lost;
    ++counters_.lost_reasons["storage_stopped"];
    return;
  }
  storage_queue_.push_back(std::move(frame));
  storage_wake_.notify_one();
}

void FramePipeline::record_lost(const std::string& reason) {
  std::lock_guard lock(mutex_);
  ++counters_.lost;
  ++counters_.lost_reasons[reason];
}

void FramePipeline::add_resent_packets(std::uint64_t packets) {
  std::lock_guard lock(mutex_);
  counters_.resent_packets += packets;
}

void FramePipeline::drain() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [&] {
    return storage_queue_.empty() && !storing_ && estimator_queue_.empty() && !estimating_;
  });
}

void FramePipeline::drain_storage() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [&] { return storage_queue_.empty() && !storing_; });
}

session::PipelineCounters FramePipeline::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

std::string FramePipeline::stored_sums_error() const {
  std::lock_guard lock(mutex_);
  return stored_sums_error_;
}

std::string FramePipeline::storage_error() const {
  std::lock_guard lock(mutex_);
  return storage_error_;
}

void FramePipeline::storage_loop() {
  std::unique_lock lock(mutex_);
  while (true) {
    storage_wake_.wait(lock, [&] { return stopping_ || !storage_queue_.empty(); });
    if (storage_queue_.empty()) {
      if (stopping_) return;
      continue;
    }
    CapturedFrame captured = std::move(storage_queue_.front());
    storage_queue_.pop_front();
    storing_ = true;
    const bool failed_before = !storage_error_.empty();
    const std::uint64_t index = next_index_;
    lock.unlock();
    space_free_.notify_all();

    std::string error;
    StoredFrame stored{index, {}, &captured};
    if (!failed_before) {
      char name[96];
      std::snprintf(name, sizeof name, "%s-%06llu.tiff", captured.record.camera.c_str(),
                    static_cast<unsigned long long>(captured.record.sequence));
      const std::filesystem::path relative = std::filesystem::path("frames") / captured.record.step / name;
      stored.file = relative.string();
      captured.record.index = index;
      captured.record.file = stored.file;
      try {
        std::filesystem::create_directories(folder_ / relative.parent_path());
        nlohmann::json record_json = session::to_json(captured.record);  // the TIFF's description and the journal's line
        session::write_frame_tiff(folder_ / relative, captured.record, record_json, captured.samples, budget_);
        journal_.append(std::move(record_json));
      } catch (const std::exception& failure) {
        error = failure.what();
      }
      if (error.empty() && options_.stored_sums) {
        // The frame is stored: a frame the sums refuse (its step's frames
        // differ in size) fails derived data, not storage.
        try {
          options_.stored_sums->add(captured.record, captured.samples);
        } catch (const std::exception& failure) {
          std::lock_guard guard(mutex_);
          if (stored_sums_error_.empty()) stored_sums_error_ = failure.what();
        }
      }
    }
    const double latency_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - captured.trigger_time).count();

    lock.lock();
    counters_.storage_cpu_ms = thread_cpu_ms();
    if (failed_before || !error.empty()) {
      if (storage_error_.empty()) storage_error_ = error;
      ++counters_.lost;
      ++counters_.lost_reasons["storage_stopped"];
      space_free_.notify_all();
    } else {
      ++next_index_;
      ++counters_.stored;
      latency_sum_ms_ += latency_ms;
      counters_.max_trigger_to_stored_ms = std::max(counters_.max_trigger_to_stored_ms, latency_ms);
      counters_.mean_trigger_to_stored_ms = latency_sum_ms_ / static_cast<double>(counters_.stored);
      lock.unlock();
      if (on_stored_) on_stored_(stored);
      lock.lock();
      if (!estimator_) {
        ++counters_.estimator_skipped;
        ++counters_.skipped_reasons["no_estimator"];
      } else if (estimator_queue_.size() >= options_.estimator_queue_frames) {
        ++counters_.estimator_skipped;
        const std::uint64_t skipped = ++counters_.skipped_reasons["queue_full"];
        if (!behind_ && on_estimator_behind_) {
          behind_ = true;
          lock.unlock();
          on_estimator_behind_(skipped);
          lock.lock();
        }
        behind_ = true;
      } else {
        behind_ = false;
        stored.frame = nullptr;
        estimator_queue_.emplace_back(std::move(captured), stored);
        counters_.estimator_queue_depth = estimator_queue_.size();
        counters_.max_estimator_queue_depth =
            std::max(counters_.max_estimator_queue_depth, counters_.estimator_queue_depth);
        estimator_wake_.notify_one();
      }
    }
    storing_ = false;  // only now: drain_storage() returns after on_stored_ acknowledged the frame
    idle_.notify_all();
  }
}

void FramePipeline::estimator_loop() {
  std::unique_lock lock(mutex_);
  while (true) {
    estimator_wake_.wait(lock, [&] { return stopping_ || !estimator_queue_.empty(); });
    if (estimator_queue_.empty()) {
      if (stopping_) return;
      continue;
    }
    auto item = std::move(estimator_queue_.front());
    estimator_queue_.pop_front();
    counters_.estimator_queue_depth = estimator_queue_.size();
    estimating_ = true;
    lock.unlock();
    item.second.frame = &item.first;
    bool ok = true;
    try {
      estimator_->consume(item.first, item.second);
    } catch (const std::exception&) {
      ok = false;
    }
    lock.lock();
    counters_.estimator_cpu_ms = thread_cpu_ms();
    estimating_ = false;
    if (ok) {
      ++counters_.estimated;
    } else {
      ++counters_.estimator_skipped;
      ++counters_.skipped_reasons["estimator_error"];
    }
    idle_.notify_all();
  }
}

}  // namespace chromo::daemon
