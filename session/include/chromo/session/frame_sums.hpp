#pragma once
// Frame sums: the one accumulator of a session's frames. The capture builder
// (session_captures.hpp) keeps its camera's frames in it, derived data
// (derived_data.hpp) is written from it, and it is filled the same way
// whichever way the frames come: live from the pipeline, or read back from the
// session folder (add_stored_frames). A TIFF holds the frame's samples
// unchanged, so both give identical sums.
//
// The sums are exact: each sample is summed as the camera sent it (the raw
// mosaic for Bayer frames, every sample of RGB8) in an unsigned 32-bit
// integer, so the order in which frames arrive does not matter. A mean is
// sum / (frames · full scale) in double, then float: units of full scale,
// 0-1. Up to kMaxFramesPerSum frames of 16-bit samples fit.
//
// Thread rules: a FrameSums, one thread at a time. A SessionFrameSums may be
// filled by one thread while another reads it: add(), find(), contains() and
// frames() lock; a FrameSums that find() returned may be read without the
// lock once its step's frames are all in (no add reaches it any more: how
// the on-line estimator reads the storage thread's sums, session_captures.hpp);
// by_step_and_camera() only when no thread adds (after
// FramePipeline::drain_storage()).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "chromo/drivers/camera.hpp"
#include "chromo/session/frame_record.hpp"

namespace chromo::session {

inline constexpr std::uint32_t kMaxFramesPerSum = 65536;  // 65535 · 65536 < 2^32

// The frames of one step from one camera.
class FrameSums {
 public:
  // The first frame fixes width, height and pixel format; a later frame that
  // differs, a samples span whose size does not match the record's geometry,
  // or a frame past kMaxFramesPerSum throws std::invalid_argument naming the
  // step and camera (nothing is added).
  void add(const FrameRecord& record, std::span<const std::uint8_t> samples);

  std::uint32_t frames() const { return frames_; }
  int width() const { return width_; }
  int height() const { return height_; }
  drivers::PixelFormat pixel_format() const { return pixel_format_; }
  // The first frame's exposure (FrameRecord::exposure_us; 0: not known). A
  // step's frames share one (the capture builder refuses a step whose do not).
  double exposure_us() const { return exposure_us_; }
  const drivers::PixelFormatInfo& format() const { return drivers::pixel_format_info(pixel_format_); }
  // width · height · samples per pixel sums, in the frame's sample order.
  const std::vector<std::uint32_t>& sums() const { return sums_; }
  // Mean of sample `i` in units of full scale (0 with no frames).
  double mean(std::size_t i) const {
    return frames_ ? static_cast<double>(sums_[i]) / (static_cast<double>(frames_) * format().full_scale()) : 0.0;
  }
  // Channel `c` (< samples per pixel) of the mean, width · height floats, row-major.
  std::vector<float> mean_channel(int c) const;

 private:
  std::uint32_t frames_ = 0;
  int width_ = 0, height_ = 0;
  drivers::PixelFormat pixel_format_ = drivers::PixelFormat::kMono8;
  double exposure_us_ = 0;
  std::vector<std::uint32_t> sums_;
};

// Every stored frame of a session, by (step, camera), and which storage
// indices are in: the one sum of a session's frames (derived data and the
// on-line estimator's captures both read it).
class SessionFrameSums {
 public:
  SessionFrameSums() = default;
  // Moves the other's sums (no thread may use `other` meanwhile).
  SessionFrameSums(SessionFrameSums&& other) noexcept;
  SessionFrameSums& operator=(SessionFrameSums&& other) noexcept;

  // Adds the frame under (record.step, record.camera) and remembers
  // record.index. Throws as FrameSums::add (nothing added then).
  void add(const FrameRecord& record, std::span<const std::uint8_t> samples);
  bool contains(std::uint64_t index) const;
  std::size_t frames() const;
  // Only while no thread adds.
  const std::map<std::pair<std::string, std::string>, FrameSums>& by_step_and_camera() const { return sums_; }
  // Null when the step has no frame of that camera. The pointer stays valid
  // as long as this object.
  const FrameSums* find(const std::string& step, const std::string& camera) const;

 private:
  mutable std::mutex mutex_;
  std::map<std::pair<std::string, std::string>, FrameSums> sums_;
  std::set<std::uint64_t> indices_;
};

// Reads the session folder's frame records (journal.jsonl) in storage order
// and calls `add` for each whose index `wanted` accepts; returns how many.
// Throws std::invalid_argument naming the journal for an unreadable record.
std::size_t for_each_stored_record(const std::filesystem::path& folder,
                                   const std::function<bool(std::uint64_t index)>& wanted,
                                   const std::function<void(const FrameRecord&)>& add);

// Reads the session folder's stored frames (the journal's frame records and
// their TIFFs) in storage order and calls `add` for each whose index `wanted`
// accepts; returns how many. Throws std::invalid_argument naming the file for
// an unreadable frame record or TIFF, or a TIFF that does not hold the frame
// its record describes.
std::size_t for_each_stored_frame(const std::filesystem::path& folder,
                                  const std::function<bool(std::uint64_t index)>& wanted,
                                  const std::function<void(const FrameRecord&, std::span<const std::uint8_t>)>& add);

// The stored frames not yet in `sums`; returns how many it added.
std::size_t add_stored_frames(SessionFrameSums& sums, const std::filesystem::path& folder);

}  // namespace chromo::session
