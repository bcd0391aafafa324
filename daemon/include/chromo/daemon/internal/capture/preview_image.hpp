#pragma once
// A camera frame made into the live view's picture: converted to 8-bit sRGB
// (a Bayer RGGB cell is one pixel, mono is grey), downscaled by sampling one
// cell per preview pixel, JPEG-encoded, with the histogram of the sampled raw
// values and a mask of the preview pixels whose cell holds a sample at full
// scale (clipped). Costs O(preview pixels), not O(frame pixels): a 5 MP frame
// at width 480 reads ~170 k cells (bench/preview_bench.cpp measures it).
// Options: white-balance gains for the picture (the histogram, mask and
// means stay raw) and a region of the frame the histogram and the means
// are taken from (the live view's positioning aids, docs/web.md "Live").

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "chromo/drivers/camera.hpp"

namespace chromo::daemon {

inline constexpr int kPreviewHistogramBins = 64;
inline constexpr int kMinPreviewWidth = 64, kMaxPreviewWidth = 1280;

// A rectangle in fractions of the frame (0-1): x, y its top-left corner.
struct PreviewRegion {
  double x = 0, y = 0, width = 1, height = 1;
};

struct PreviewOptions {
  int width = 480;                                // preview width in pixels
  std::array<double, 3> white_balance_gains{1, 1, 1};  // R, G, B multipliers of the picture, each in (0, 64]
  PreviewRegion region;                           // of the histogram and means
};

struct PreviewImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> jpeg;
  std::vector<std::uint8_t> clipped_mask;  // one bit per pixel, row-major, least significant bit first
  std::uint32_t clipped_pixels = 0;
  std::array<std::uint32_t, kPreviewHistogramBins> histogram{};  // sampled raw values in the region over [0, full_scale]
  std::uint32_t full_scale = 0;
  // The region's sampled cells (preview pixels inside it; at least one) and
  // their raw mean per channel: R, G, B (a Bayer cell's G the mean of its
  // two), one value for mono.
  std::uint32_t region_cells = 0;
  std::vector<double> region_mean;
  int region_x = 0, region_y = 0, region_width = 0, region_height = 0;  // in preview pixels
};

// `samples` as the camera sent them (drivers::PixelFormatInfo's layout).
// Throws std::invalid_argument when the sizes do not match the format or
// preview_width is outside [kMinPreviewWidth, kMaxPreviewWidth]. A frame
// narrower than preview_width keeps its own width (never upscaled).
PreviewImage make_preview(int frame_width, int frame_height, drivers::PixelFormat format,
                          std::span<const std::uint8_t> samples, int preview_width);
// The same with gains and a region; std::invalid_argument naming
// "white_balance_gains" or "region" (outside the frame, or empty) too.
PreviewImage make_preview(int frame_width, int frame_height, drivers::PixelFormat format,
                          std::span<const std::uint8_t> samples, const PreviewOptions& options);

}  // namespace chromo::daemon
