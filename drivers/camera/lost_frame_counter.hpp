#pragma once
// LostFrameCounter: the frames a GigE Vision link lost before the driver saw
// them, from the gaps in the camera's block ids (internal to AravisCamera;
// unit-tested on its own). Used by the stream thread only.

#include <cstdint>
#include <optional>
#include <set>

namespace chromo::drivers::detail {

// How many block ids `current` is ahead of `previous` (1 = the next frame),
// or nullopt when it is behind (a late frame) or the camera restarted. GigE
// Vision 1.x block ids are 16 bits and skip 0 when they wrap.
inline std::optional<std::uint64_t> frames_ahead(std::uint64_t previous, std::uint64_t current) {
  if (current > previous) return current - previous;
  if (previous >= 0xF000 && previous <= 0xFFFF && current < 0x1000 && current >= 1)
    return (0xFFFF - previous) + current;
  return std::nullopt;
}
inline std::uint64_t next_block_id(std::uint64_t id) { return id == 0xFFFF ? 1 : id + 1; }

// Counts the frames the link lost before the driver saw them, from the gaps
// in the camera's block ids. A gap is provisional: Aravis may deliver a frame
// late (after a newer one, when it waited for resends); it is then taken back.
class LostFrameCounter {
 public:
  void reset() {
    last_.reset();
    provisional_.clear();
  }
  // A failed buffer can come back from Aravis with the block id (and
  // timestamps) of the frame it held before (seen with Aravis 0.8.26 when a
  // frame's leader packet was lost): an id behind the newest one that is not
  // a gap we are waiting for.
  bool is_stale(std::uint64_t id) const {
    return id == 0 || (last_ && !frames_ahead(*last_, id) && provisional_.count(id) == 0);
  }
  // Returns the change in the lost count for a delivered frame (may be -1).
  std::int64_t on_frame(std::uint64_t id) {
    if (!last_) {
      last_ = id;
      return 0;
    }
    const auto ahead = frames_ahead(*last_, id);
    if (!ahead) {
      if (provisional_.erase(id) > 0) return -1;  // late, not lost after all
      if (id + kRemembered < *last_) {            // far behind: the camera restarted its count
        last_ = id;
        provisional_.clear();
      }
      return 0;  // close behind: a duplicate, counted once already
    }
    std::uint64_t skipped = *ahead - 1;
    for (std::uint64_t k = 0, missing = next_block_id(*last_); k < skipped && k < kRemembered; ++k) {
      provisional_.insert(missing);
      missing = next_block_id(missing);
    }
    while (provisional_.size() > kRemembered) provisional_.erase(provisional_.begin());
    last_ = id;
    return static_cast<std::int64_t>(skipped);
  }
  // A failed frame without a trustworthy id: it is the oldest frame still
  // counted as missing, if any, else the next one.
  std::int64_t on_frame_without_id() {
    if (!provisional_.empty()) {
      provisional_.erase(provisional_.begin());
      return -1;
    }
    if (last_) last_ = next_block_id(*last_);
    return 0;
  }

 private:
  static constexpr std::size_t kRemembered = 256;
  std::optional<std::uint64_t> last_;
  std::set<std::uint64_t> provisional_;
};

}  // namespace chromo::drivers::detail
