#include "chromo/daemon/internal/capture/preview_image.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace chromo::daemon {

namespace {

// Raw value → 8-bit sRGB-encoded grey level, one entry per raw value.
std::vector<std::uint8_t> srgb_table(std::uint32_t full_scale) {
  std::vector<std::uint8_t> table(full_scale + 1);
  for (std::uint32_t v = 0; v <= full_scale; ++v) {
    const double linear = static_cast<double>(v) / full_scale;
    const double encoded = linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
    table[v] = static_cast<std::uint8_t>(std::lround(encoded * 255));
  }
  return table;
}

const std::vector<std::uint8_t>& srgb_table_of(int significant_bits) {
  static const std::vector<std::uint8_t> bits8 = srgb_table(255), bits12 = srgb_table(4095), bits16 = srgb_table(65535);
  return significant_bits == 8 ? bits8 : significant_bits == 12 ? bits12 : bits16;
}

}  // namespace

PreviewImage make_preview(int frame_width, int frame_height, drivers::PixelFormat format,
                          std::span<const std::uint8_t> samples, int preview_width) {
  PreviewOptions options;
  options.width = preview_width;
  return make_preview(frame_width, frame_height, format, samples, options);
}

PreviewImage make_preview(int frame_width, int frame_height, drivers::PixelFormat format,
                          std::span<const std::uint8_t> samples, const PreviewOptions& options) {
  const int preview_width = options.width;
  for (double gain : options.white_balance_gains)
    if (!(gain > 0 && gain <= 64)) throw std::invalid_argument("white_balance_gains: each must be in (0, 64]");
  const PreviewRegion& region = options.region;
  if (!(region.x >= 0 && region.y >= 0 && region.width > 0 && region.height > 0 && region.x + region.width <= 1 + 1e-9 &&
        region.y + region.height <= 1 + 1e-9))
    throw std::invalid_argument("region: must lie inside the frame (x, y >= 0, width, height > 0, x + width and y + height <= 1)");
  const auto& info = drivers::pixel_format_info(format);
  if (preview_width < kMinPreviewWidth || preview_width > kMaxPreviewWidth)
    throw std::invalid_argument("width: " + std::to_string(preview_width) + " is outside [" +
                                std::to_string(kMinPreviewWidth) + ", " + std::to_string(kMaxPreviewWidth) + "]");
  if (frame_width <= 0 || frame_height <= 0 || samples.size() != info.frame_bytes(frame_width, frame_height))
    throw std::invalid_argument("frame: " + std::to_string(samples.size()) + " bytes do not hold " +
                                std::to_string(frame_width) + "x" + std::to_string(frame_height) + " " +
                                std::string(info.name));
  const int cell = info.layout == drivers::ColourLayout::kBayerRGGB ? 2 : 1;
  const int cells_x = frame_width / cell, cells_y = frame_height / cell;
  if (cells_x == 0 || cells_y == 0) throw std::invalid_argument("frame: smaller than one colour cell");
  PreviewImage image;
  image.full_scale = info.full_scale();
  image.width = std::min(preview_width, cells_x);
  image.height = std::max(1, static_cast<int>(std::lround(static_cast<double>(cells_y) * image.width / cells_x)));
  image.clipped_mask.assign((static_cast<std::size_t>(image.width) * image.height + 7) / 8, 0);
  const auto& to_srgb = srgb_table_of(info.significant_bits);
  // The region in preview pixels: at least one.
  image.region_x = std::min(image.width - 1, static_cast<int>(std::floor(region.x * image.width)));
  image.region_y = std::min(image.height - 1, static_cast<int>(std::floor(region.y * image.height)));
  image.region_width = std::clamp(static_cast<int>(std::ceil((region.x + region.width) * image.width)) - image.region_x, 1,
                                  image.width - image.region_x);
  image.region_height = std::clamp(static_cast<int>(std::ceil((region.y + region.height) * image.height)) - image.region_y,
                                   1, image.height - image.region_y);
  const bool mono = info.layout != drivers::ColourLayout::kBayerRGGB && info.layout != drivers::ColourLayout::kRgb;
  std::array<double, 3> sums{};
  // Gains applied to the picture only, in raw units, at full scale at most.
  const auto& gains = options.white_balance_gains;
  const auto balanced = [&](std::uint32_t value, int channel) {
    if (gains[channel] == 1) return value;
    return static_cast<std::uint32_t>(std::min<double>(image.full_scale, std::lround(value * gains[channel])));
  };
  const int bin_shift = info.significant_bits - 6;  // 64 bins
  const std::size_t row_bytes = static_cast<std::size_t>(frame_width) * info.samples_per_pixel * info.bytes_per_sample;
  auto sample_at = [&](int x, int y, int channel) -> std::uint32_t {
    const std::size_t offset = static_cast<std::size_t>(y) * row_bytes +
                               (static_cast<std::size_t>(x) * info.samples_per_pixel + channel) * info.bytes_per_sample;
    return info.bytes_per_sample == 1 ? samples[offset] : samples[offset] | (samples[offset + 1] << 8);
  };
  cv::Mat bgr(image.height, image.width, CV_8UC3);
  for (int y = 0; y < image.height; ++y) {
    const int cy = static_cast<int>((static_cast<long>(2 * y + 1) * cells_y) / (2L * image.height));
    auto* out = bgr.ptr<std::uint8_t>(y);
    for (int x = 0; x < image.width; ++x) {
      const int cx = static_cast<int>((static_cast<long>(2 * x + 1) * cells_x) / (2L * image.width));
      std::uint32_t r, g, b, brightest;
      const bool in_region = x >= image.region_x && x < image.region_x + image.region_width && y >= image.region_y &&
                             y < image.region_y + image.region_height;
      if (info.layout == drivers::ColourLayout::kBayerRGGB) {
        const int sx = cx * 2, sy = cy * 2;
        r = sample_at(sx, sy, 0);
        const std::uint32_t g1 = sample_at(sx + 1, sy, 0), g2 = sample_at(sx, sy + 1, 0);
        b = sample_at(sx + 1, sy + 1, 0);
        g = (g1 + g2) / 2;
        brightest = std::max({r, g1, g2, b});
        if (in_region) {
          ++image.histogram[r >> bin_shift], ++image.histogram[g1 >> bin_shift], ++image.histogram[g2 >> bin_shift],
              ++image.histogram[b >> bin_shift];
          sums[0] += r, sums[1] += (g1 + g2) / 2.0, sums[2] += b;
        }
      } else if (info.layout == drivers::ColourLayout::kRgb) {
        r = sample_at(cx, cy, 0), g = sample_at(cx, cy, 1), b = sample_at(cx, cy, 2);
        brightest = std::max({r, g, b});
        if (in_region) {
          ++image.histogram[r >> bin_shift], ++image.histogram[g >> bin_shift], ++image.histogram[b >> bin_shift];
          sums[0] += r, sums[1] += g, sums[2] += b;
        }
      } else {
        r = g = b = brightest = sample_at(cx, cy, 0);
        if (in_region) ++image.histogram[r >> bin_shift], sums[0] += r;
      }
      image.region_cells += in_region;
      if (!mono) r = balanced(r, 0), g = balanced(g, 1), b = balanced(b, 2);
      out[3 * x] = to_srgb[b], out[3 * x + 1] = to_srgb[g], out[3 * x + 2] = to_srgb[r];
      if (brightest >= image.full_scale) {
        const std::size_t bit = static_cast<std::size_t>(y) * image.width + x;
        image.clipped_mask[bit / 8] |= static_cast<std::uint8_t>(1u << (bit % 8));
        ++image.clipped_pixels;
      }
    }
  }
  for (int c = 0; c < (mono ? 1 : 3); ++c) image.region_mean.push_back(sums[c] / image.region_cells);
  if (!cv::imencode(".jpg", bgr, image.jpeg, {cv::IMWRITE_JPEG_QUALITY, 80}))
    throw std::runtime_error("preview: JPEG encoding failed");
  return image;
}

}  // namespace chromo::daemon
