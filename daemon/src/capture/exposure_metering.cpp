#include "chromo/daemon/internal/capture/exposure_metering.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace chromo::daemon {

int FrameLevels::brightest_channel() const {
  return static_cast<int>(std::max_element(mean.begin(), mean.end()) - mean.begin());
}

namespace {

using ChannelHistograms = std::array<std::vector<std::uint64_t>, 3>;

// A raw frame's samples read by position: each sample's value (clamped to
// full scale) and colour channel (RGGB sites; mono frames channel 0). The
// constructor refuses a buffer whose size is not the frame's.
class FrameSamples {
 public:
  FrameSamples(std::span<const std::uint8_t> samples, int width, int height, const drivers::PixelFormatInfo& info)
      : samples_(samples), width_(width), info_(info), top_(static_cast<std::uint32_t>(info.full_scale())) {
    if (width <= 0 || height <= 0 || samples.size() != info.frame_bytes(width, height))
      throw std::invalid_argument("metering frame: " + std::to_string(samples.size()) + " bytes for a " +
                                  std::to_string(width) + "x" + std::to_string(height) + " " + std::string(info.name) +
                                  " frame");
  }
  std::uint32_t top() const { return top_; }
  std::uint32_t value(int x, int y, int s) const {
    const std::size_t i = (static_cast<std::size_t>(y) * width_ + x) * info_.samples_per_pixel + s;
    if (info_.bytes_per_sample == 1) return std::min<std::uint32_t>(samples_[i], top_);
    std::uint16_t v;
    std::memcpy(&v, samples_.data() + 2 * i, 2);
    return std::min<std::uint32_t>(v, top_);
  }
  int channel(int x, int y, int s) const {
    if (info_.layout == drivers::ColourLayout::kBayerRGGB) return (y % 2 == 0 && x % 2 == 0) ? 0 : (y % 2 && x % 2) ? 2 : 1;
    return info_.layout == drivers::ColourLayout::kMono ? 0 : s;
  }

 private:
  std::span<const std::uint8_t> samples_;
  int width_;
  const drivers::PixelFormatInfo& info_;
  std::uint32_t top_;
};

// Each channel's histogram of sample values (0 … full scale; a value above it
// counts as full scale); mono frames fill channel 0 only.
ChannelHistograms channel_histograms(std::span<const std::uint8_t> samples, int width, int height,
                                     const drivers::PixelFormatInfo& info) {
  const FrameSamples frame(samples, width, height, info);
  ChannelHistograms histogram;
  for (auto& h : histogram) h.assign(frame.top() + 1, 0);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int s = 0; s < info.samples_per_pixel; ++s) ++histogram[frame.channel(x, y, s)][frame.value(x, y, s)];
  return histogram;
}

// The value below which a share q of the histogram's samples in [0, end) lie
// (count: their number, > 0).
std::uint32_t histogram_percentile(const std::vector<std::uint64_t>& h, std::uint32_t end, std::uint64_t count, double q) {
  const auto wanted = static_cast<std::uint64_t>(q * static_cast<double>(count - 1));
  std::uint64_t below = 0;
  for (std::uint32_t v = 0; v < end; ++v)
    if ((below += h[v]) > wanted) return v;
  return end - 1;
}

}  // namespace

FrameLevels frame_levels(std::span<const std::uint8_t> samples, int width, int height, drivers::PixelFormat format,
                         FrameRegion region) {
  const auto& info = drivers::pixel_format_info(format);
  const ChannelHistograms histogram = channel_histograms(samples, width, height, info);
  const double full = info.full_scale();
  const auto top = static_cast<std::uint32_t>(info.full_scale());
  FrameLevels levels;
  for (int c = 0; c < 3; ++c) {
    const auto& h = histogram[info.layout == drivers::ColourLayout::kMono ? 0 : c];
    std::uint64_t count = 0;
    for (auto n : h) count += n;
    if (count == 0) continue;
    auto percentile = [&](double q) { return histogram_percentile(h, top + 1, count, q); };
    std::uint32_t from = 0;
    if (region == FrameRegion::kLit) {
      const std::uint32_t low = percentile(kLitLowPercentile), high = percentile(kLitHighPercentile);
      if (2.0 * low < high) from = low + (high - low + 1) / 2;  // a dark surround: the lit part only
    }
    double sum = 0;
    std::uint64_t in_region = 0;
    for (std::uint32_t v = from; v <= top; ++v) sum += static_cast<double>(v) * static_cast<double>(h[v]), in_region += h[v];
    levels.mean[c] = in_region ? sum / (full * static_cast<double>(in_region)) : 0.0;
    levels.clipped[c] = in_region ? static_cast<double>(h[top]) / static_cast<double>(in_region) : 0.0;
    levels.region_share[c] = static_cast<double>(in_region) / static_cast<double>(count);
  }
  return levels;
}

MeteringDecision next_metering_exposure(double exposure_us, const FrameLevels& levels, const MeteringTarget& target) {
  MeteringDecision d;
  const auto clamp = [&](double t) { return std::clamp(t, target.min_exposure_us, target.max_exposure_us); };
  const int c = levels.brightest_channel();
  const double brightest = levels.mean[c];
  d.clipped = brightest >= 0.99 || *std::max_element(levels.clipped.begin(), levels.clipped.end()) > 0.001;
  if (d.clipped) {
    if (exposure_us <= target.min_exposure_us) {
      d.next_exposure_us = target.min_exposure_us, d.done = true, d.at_limit = true;
      return d;
    }
    d.next_exposure_us = clamp(exposure_us * std::min(0.5, target.white_share / brightest));
    return d;
  }
  const double signal = brightest - target.dark[c], wanted = target.white_share - target.dark[c];
  const double ratio = signal > 1e-4 ? wanted / signal : 16.0;
  d.next_exposure_us = clamp(exposure_us * ratio);
  if (std::abs(ratio - 1) <= target.tolerance) d.done = true;
  if (ratio > 1 && exposure_us >= target.max_exposure_us) d.done = true, d.at_limit = true;
  return d;
}

SubjectLevels subject_levels(std::span<const std::uint8_t> samples, int width, int height, drivers::PixelFormat format,
                             double percentile, const std::array<double, 3>& white_like_from) {
  if (!(percentile > 0 && percentile <= 1))
    throw std::invalid_argument("subject_percentile: must be in (0, 1], got " + std::to_string(percentile));
  const auto& info = drivers::pixel_format_info(format);
  const FrameSamples frame(samples, width, height, info);
  const auto top = frame.top();
  const bool bayer = info.layout == drivers::ColourLayout::kBayerRGGB;
  std::array<std::uint32_t, 3> ceiling{};
  for (int c = 0; c < 3; ++c)
    ceiling[c] = static_cast<std::uint32_t>(std::clamp(std::ceil(std::clamp(white_like_from[c], 0.0, 1.0) * top), 0.0,
                                                       static_cast<double>(top)));
  // Cells: a Bayer frame's 2×2 RGGB quads, else pixels. A cell is white-like
  // when any of its samples reaches its channel's ceiling.
  const int cell = bayer ? 2 : 1;
  const int cells_x = (width + cell - 1) / cell, cells_y = (height + cell - 1) / cell;
  std::vector<std::uint8_t> white_like(static_cast<std::size_t>(cells_x) * cells_y, 0);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int s = 0; s < info.samples_per_pixel; ++s)
        if (frame.value(x, y, s) >= ceiling[frame.channel(x, y, s)])
          white_like[static_cast<std::size_t>(y / cell) * cells_x + x / cell] = 1;
  // Grown by the margin (a square of ± margin cells): the target's edge.
  const int margin = std::max(kSubjectWhiteLikeMarginCells,
                              static_cast<int>(std::lround(kSubjectWhiteLikeMarginShare * cells_x)));
  // One pass of the square's max filter: along x (step 1) or along y (step cells_x).
  auto grow = [&](const std::vector<std::uint8_t>& in, bool along_x) {
    std::vector<std::uint8_t> out(in.size(), 0);
    const int length = along_x ? cells_x : cells_y;
    const std::size_t step = along_x ? 1 : static_cast<std::size_t>(cells_x);
    for (int y = 0; y < cells_y; ++y)
      for (int x = 0; x < cells_x; ++x) {
        const int at = along_x ? x : y;
        const std::size_t line = static_cast<std::size_t>(y) * cells_x + x - static_cast<std::size_t>(at) * step;
        std::uint8_t any = 0;
        for (int d = std::max(0, at - margin); d <= std::min(length - 1, at + margin) && !any; ++d)
          any = in[line + static_cast<std::size_t>(d) * step];
        out[static_cast<std::size_t>(y) * cells_x + x] = any;
      }
    return out;
  };
  const std::vector<std::uint8_t> excluded = grow(grow(white_like, true), false);
  std::size_t excluded_cells = 0;
  for (auto v : excluded) excluded_cells += v;
  ChannelHistograms histogram;
  for (auto& h : histogram) h.assign(top + 1, 0);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      if (excluded[static_cast<std::size_t>(y / cell) * cells_x + x / cell]) continue;
      for (int s = 0; s < info.samples_per_pixel; ++s) ++histogram[frame.channel(x, y, s)][frame.value(x, y, s)];
    }
  SubjectLevels levels;
  levels.white_like_share = static_cast<double>(excluded_cells) / static_cast<double>(white_like.size());
  for (int c = 0; c < 3; ++c) {
    const auto& h = histogram[info.layout == drivers::ColourLayout::kMono ? 0 : c];
    std::uint64_t count = 0;
    for (auto n : h) count += n;
    if (count > 0) levels.level[c] = static_cast<double>(histogram_percentile(h, top + 1, count, percentile)) / top;
  }
  return levels;
}

}  // namespace chromo::daemon
