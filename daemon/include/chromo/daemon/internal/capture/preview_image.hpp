#pragma once
// A camera frame made into the live view's picture: converted to 8-bit sRGB
// (a Bayer RGGB cell is one pixel, mono is grey), downscaled by sampling one
// cell per preview pixel, JPEG-encoded, with the histogram of the sampled raw
// values and a mask of the preview pixels whose cell holds a sample at full
// scale (clipped). Costs O(preview pixels), not O(frame pixels): a 5 MP frame
// at width 480 reads ~170 k cells (bench/preview_bench.cpp measures it).

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "chromo/drivers/camera.hpp"

namespace chromo::daemon {

inline constexpr int kPreviewHistogramBins = 64;
inline constexpr int kMinPreviewWidth = 64, kMaxPreviewWidth = 1280;

struct PreviewImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> jpeg;
  std::vector<std::uint8_t> clipped_mask;  // one bit per pixel, row-major, least significant bit first
  std::uint32_t clipped_pixels = 0;
  std::array<std::uint32_t, kPreviewHistogramBins> histogram{};  // sampled raw values over [0, full_scale]
  std::uint32_t full_scale = 0;
};

// `samples` as the camera sent them (drivers::PixelFormatInfo's layout).
// Throws std::invalid_argument when the sizes do not match the format or
// preview_width is outside [kMinPreviewWidth, kMaxPreviewWidth]. A frame
// narrower than preview_width keeps its own width (never upscaled).
PreviewImage make_preview(int frame_width, int frame_height, drivers::PixelFormat format,
                          std::span<const std::uint8_t> samples, int preview_width);

}  // namespace chromo::daemon
