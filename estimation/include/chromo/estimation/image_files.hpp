#pragma once
// Image files of the estimator, the offline commands and the daemon: OpenEXR float images (read any
// channels, half or float, as float; write float channels) and preview PNGs
// with a colour bar (OpenCV). Errors throw ImageError naming the file.

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace chromo::estimation {

class ImageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct FloatImage {
  int width = 0, height = 0;
  std::vector<std::string> channel_names;
  std::vector<std::vector<float>> channels;  // width × height each, row-major
  const std::vector<float>& channel(const std::string& name) const;  // ImageError if absent
};

FloatImage read_exr(const std::filesystem::path& path);
void write_exr(const std::filesystem::path& path, const FloatImage& image);

// A false-colour map (viridis) of values in [low, high] (log scale if asked),
// pixels where hide[i] is set in grey, with a colour bar and its range on the right.
void write_map_png(const std::filesystem::path& path, const std::vector<float>& values, int width, int height,
                   double low, double high, bool log_scale, const std::string& label,
                   const std::vector<std::uint8_t>& hide);
// Categorical map (flags, order): one colour per code with a legend.
void write_category_png(const std::filesystem::path& path, const std::vector<float>& codes, int width, int height,
                        const std::vector<std::string>& names);

}  // namespace chromo::estimation
