#pragma once
// CamerasProgress: a session's Progress shared by its cameras' estimates
// running at once (camera_results.cpp). Each camera gets a Progress of its
// own (of_camera); their calls reach the session's one at a time, as
// files::Progress requires, its fraction the mean of the cameras' fractions
// (never decreasing, since each camera's does not) and its step prefixed by
// the camera's name. Cancelling the session cancels every camera.
//
// Thread rules: of_camera() before the cameras start; the Progress it
// returns may be called from any thread; the object outlives the cameras.

#include <mutex>
#include <string>
#include <vector>

#include "chromo/files/progress.hpp"

namespace chromo::maps::detail {

class CamerasProgress {
 public:
  CamerasProgress(files::Progress session, std::vector<std::string> cameras)
      : session_(std::move(session)), cameras_(std::move(cameras)), fractions_(cameras_.size(), 0.0) {}

  files::Progress of_camera(std::size_t k) {
    files::Progress p;
    if (session_.on_progress)
      p.on_progress = [this, k](double fraction, const std::string& step) {
        std::lock_guard lock(mutex_);
        fractions_[k] = fraction;
        double sum = 0;
        for (double f : fractions_) sum += f;
        session_.report(sum / static_cast<double>(fractions_.size()), cameras_[k] + ": " + step);
      };
    if (session_.should_cancel)
      p.should_cancel = [this] {
        std::lock_guard lock(mutex_);
        return session_.cancelled();
      };
    return p;
  }

 private:
  files::Progress session_;
  std::vector<std::string> cameras_;
  std::vector<double> fractions_;
  std::mutex mutex_;
};

}  // namespace chromo::maps::detail
