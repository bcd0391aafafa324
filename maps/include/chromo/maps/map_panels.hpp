#pragma once
// Pictures of relit maps for people: sRGB previews, ΔE heat maps with a
// colour bar, and side-by-side panels with titles (OpenCV imgproc; 8-bit BGR
// cv::Mat, as cv::imwrite expects). Thread-safe.

#include <opencv2/core.hpp>
#include <cstdint>
#include <string>
#include <vector>

namespace chromo::maps {

// Encoded, clipped sRGB preview of linear RGB (pixel-major, 3 per pixel);
// pixels with valid[i] == 0 (if valid is not empty) in mid grey.
cv::Mat srgb_preview(const std::vector<float>& linear_rgb, int width, int height,
                     const std::vector<std::uint8_t>& valid = {});

// Heat map (inferno) of values in [0, high]; non-finite values in grey. With
// a colour bar on the right labelled `label` and ticks at 0, high/2, high.
cv::Mat heat_map_with_bar(const std::vector<double>& values, int width, int height, double high,
                          const std::string& label);

struct PanelTile {
  std::string title;
  cv::Mat image;  // CV_8UC3
};
// Tiles left to right with their titles above and an optional caption line
// below (e.g. "ΔE94 mean 0.41 median 0.33 p95 1.02"). ASCII text only (Hershey fonts).
cv::Mat side_by_side(const std::vector<PanelTile>& tiles, const std::string& caption = {});

// cv::imwrite or throw std::runtime_error naming the file.
void write_png(const std::string& path, const cv::Mat& image);

}  // namespace chromo::maps
