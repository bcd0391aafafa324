#include "chromo/daemon/exposure_metering.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace chromo::daemon {

int FrameLevels::brightest_channel() const {
  return static_cast<int>(std::max_element(mean.begin(), mean.end()) - mean.begin());
}

FrameLevels frame_levels(std::span<const std::uint8_t> samples, int width, int height, drivers::PixelFormat format) {
  const auto& info = drivers::pixel_format_info(format);
  if (width <= 0 || height <= 0 || samples.size() != info.frame_bytes(width, height))
    throw std::invalid_argument("metering frame: " + std::to_string(samples.size()) + " bytes for a " +
                                std::to_string(width) + "x" + std::to_string(height) + " " + std::string(info.name) +
                                " frame");
  const double full = info.full_scale();
  std::array<double, 3> sum{};
  std::array<std::uint64_t, 3> count{}, at_full{};
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
        const std::uint32_t v = sample((static_cast<std::size_t>(y) * width + x) * info.samples_per_pixel + s);
        sum[c] += v, ++count[c];
        if (v >= info.full_scale()) ++at_full[c];
      }
  FrameLevels levels;
  for (int c = 0; c < 3; ++c) {
    const int from = info.layout == drivers::ColourLayout::kMono ? 0 : c;
    levels.mean[c] = count[from] ? sum[from] / (full * static_cast<double>(count[from])) : 0.0;
    levels.clipped[c] = count[from] ? static_cast<double>(at_full[from]) / static_cast<double>(count[from]) : 0.0;
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
