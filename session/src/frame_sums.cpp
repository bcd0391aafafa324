#include "chromo/session/frame_sums.hpp"

#include <cstring>
#include <stdexcept>

#include "chromo/session/frame_files.hpp"
#include "chromo/session/journal.hpp"

namespace chromo::session {

void FrameSums::add(const FrameRecord& record, std::span<const std::uint8_t> samples) {
  const auto& info = drivers::pixel_format_info(record.pixel_format);
  const std::string what = "step " + record.step + ", camera " + record.camera + ": ";
  if (record.width <= 0 || record.height <= 0 || samples.size() != info.frame_bytes(record.width, record.height))
    throw std::invalid_argument(what + std::to_string(samples.size()) + " bytes do not make a " +
                                std::to_string(record.width) + "×" + std::to_string(record.height) + " " +
                                std::string(info.name) + " frame");
  if (frames_ == 0) {
    width_ = record.width, height_ = record.height, pixel_format_ = record.pixel_format;
    exposure_us_ = record.exposure_us;
    sums_.assign(static_cast<std::size_t>(width_) * height_ * info.samples_per_pixel, 0u);
  } else if (record.width != width_ || record.height != height_ || record.pixel_format != pixel_format_) {
    throw std::invalid_argument(what + "frames of one step differ in size or pixel format (" +
                                std::to_string(width_) + "×" + std::to_string(height_) + " " +
                                std::string(format().name) + ", then " + std::to_string(record.width) + "×" +
                                std::to_string(record.height) + " " + std::string(info.name) + ")");
  } else if (frames_ >= kMaxFramesPerSum) {
    throw std::invalid_argument(what + "more than " + std::to_string(kMaxFramesPerSum) + " frames");
  }
  if (info.bytes_per_sample == 1) {
    for (std::size_t i = 0; i < sums_.size(); ++i) sums_[i] += samples[i];
  } else {
    for (std::size_t i = 0; i < sums_.size(); ++i) {
      std::uint16_t value;
      std::memcpy(&value, &samples[2 * i], 2);
      sums_[i] += value;
    }
  }
  ++frames_;
}

std::vector<float> FrameSums::mean_channel(int c) const {
  const auto samples = static_cast<std::size_t>(format().samples_per_pixel);
  std::vector<float> out(static_cast<std::size_t>(width_) * height_);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<float>(mean(i * samples + static_cast<std::size_t>(c)));
  return out;
}

SessionFrameSums::SessionFrameSums(SessionFrameSums&& other) noexcept {
  std::lock_guard lock(other.mutex_);
  sums_ = std::move(other.sums_);
  indices_ = std::move(other.indices_);
}

SessionFrameSums& SessionFrameSums::operator=(SessionFrameSums&& other) noexcept {
  if (this == &other) return *this;
  std::scoped_lock lock(mutex_, other.mutex_);
  sums_ = std::move(other.sums_);
  indices_ = std::move(other.indices_);
  return *this;
}

void SessionFrameSums::add(const FrameRecord& record, std::span<const std::uint8_t> samples) {
  std::lock_guard lock(mutex_);
  const auto key = std::make_pair(record.step, record.camera);
  const bool fresh = !sums_.count(key);
  try {
    sums_[key].add(record, samples);
  } catch (...) {
    if (fresh) sums_.erase(key);
    throw;
  }
  indices_.insert(record.index);
}

bool SessionFrameSums::contains(std::uint64_t index) const {
  std::lock_guard lock(mutex_);
  return indices_.count(index) != 0;
}

std::size_t SessionFrameSums::frames() const {
  std::lock_guard lock(mutex_);
  return indices_.size();
}

const FrameSums* SessionFrameSums::find(const std::string& step, const std::string& camera) const {
  std::lock_guard lock(mutex_);
  const auto it = sums_.find({step, camera});
  return it == sums_.end() ? nullptr : &it->second;
}

std::size_t for_each_stored_record(const std::filesystem::path& folder,
                                   const std::function<bool(std::uint64_t index)>& wanted,
                                   const std::function<void(const FrameRecord&)>& add) {
  std::size_t count = 0;
  for (const auto& json : read_journal(folder / "journal.jsonl").records) {
    if (json.value("type", "") != "frame") continue;
    FrameRecord record;
    try {
      record = frame_record_from_json(json);
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument((folder / "journal.jsonl").string() + ": " + error.what());
    }
    if (!wanted(record.index)) continue;
    add(record);
    ++count;
  }
  return count;
}

std::size_t for_each_stored_frame(const std::filesystem::path& folder,
                                  const std::function<bool(std::uint64_t index)>& wanted,
                                  const std::function<void(const FrameRecord&, std::span<const std::uint8_t>)>& add) {
  return for_each_stored_record(folder, wanted, [&](const FrameRecord& record) {
    const std::filesystem::path file = folder / record.file;
    TiffImage image;
    try {
      image = read_tiff(file);
    } catch (const std::exception& error) {
      throw std::invalid_argument(file.string() + ": " + error.what());
    }
    const auto& info = drivers::pixel_format_info(record.pixel_format);
    if (image.width != record.width || image.height != record.height ||
        image.samples_per_pixel != info.samples_per_pixel || image.bits_per_sample != 8 * info.bytes_per_sample)
      throw std::invalid_argument(file.string() + ": a " + std::to_string(image.width) + "×" +
                                  std::to_string(image.height) + " TIFF of " + std::to_string(image.samples_per_pixel) +
                                  "×" + std::to_string(image.bits_per_sample) + "-bit samples, but its record says " +
                                  std::to_string(record.width) + "×" + std::to_string(record.height) + " " +
                                  std::string(info.name));
    add(record, image.data);
  });
}

std::size_t add_stored_frames(SessionFrameSums& sums, const std::filesystem::path& folder) {
  return for_each_stored_frame(
      folder, [&](std::uint64_t index) { return !sums.contains(index); },
      [&](const FrameRecord& record, std::span<const std::uint8_t> samples) { sums.add(record, samples); });
}

}  // namespace chromo::session
