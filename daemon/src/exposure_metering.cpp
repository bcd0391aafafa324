#include "chromo/daemon/exposure_metering.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace chromo::daemon {

int FrameLevels::brightest_channel() const {
  return static_cast<int>(std::max_element(mean.begin(), mean.end()) - mean.begin());
}

FrameLevels frame_levels(std::span<const std::uint8_t> samples, int width, int height, drivers::PixelFormat format,
                         FrameRegion region, double high_percentile) {
  const auto& info = drivers::pixel_format_info(format);
  if (width <= 0 || height <= 0 || samples.size() != info.frame_bytes(width, height))
    throw std::invalid_argument("metering frame: " + std::to_string(samples.size()) + " bytes for a " +
                                std::to_string(width) + "x" + std::to_string(height) + " " + std::string(info.name) +
                                " frame");
  const double full = info.full_scale();
  const auto top = static_cast<std::uint32_t>(info.full_scale());
  // Each channel's histogram of sample values (0 … full scale; a value above
  // it counts as full scale).
  std::array<std::vector<std::uint64_t>, 3> histogram;
  for (auto& h : histogram) h.assign(top + 1, 0);
  auto sample = [&](std::size_t i) -> std::uint32_t {
    if (info.bytes_per_sample == 1) return samples[i];
    std::uint16_t v;
    std::memcpy(&v, samples.data() + 2 * i, 2);
    return v;
  };
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int s = 0; s < info.samples_per_pixel; ++s) {
        int c = s;
        if (info.layout == drivers::ColourLayout::kBayerRGGB) c = (y % 2 == 0 && x % 2 == 0) ? 0 : (y % 2 && x % 2) ? 2 : 1;
        else if (info.layout == drivers::ColourLayout::kMono) c = 0;
        ++histogram[c][std::min(sample((static_cast<std::size_t>(y) * width + x) * info.samples_per_pixel + s), top)];
      }
  FrameLevels levels;
  for (int c = 0; c < 3; ++c) {
    const auto& h = histogram[info.layout == drivers::ColourLayout::kMono ? 0 : c];
    std::uint64_t count = 0;
    for (auto n : h) count += n;
    if (count == 0) continue;
    // The value below which a share q of the samples lie.
    auto percentile = [&](double q) {
      const auto wanted = static_cast<std::uint64_t>(q * static_cast<double>(count - 1));
      std::uint64_t below = 0;
      for (std::uint32_t v = 0; v <= top; ++v)
        if ((below += h[v]) > wanted) return v;
      return top;
    };
    levels.high[c] = static_cast<double>(percentile(std::clamp(high_percentile, 0.0, 1.0))) / full;
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

}  // namespace chromo::daemon
