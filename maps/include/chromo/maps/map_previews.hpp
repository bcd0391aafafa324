#pragma once
// Preview PNGs of parameter maps (OpenCV): false colour with a colour bar, or
// categories with a legend. Errors throw files::ImageError naming the file.
// Thread rules: free functions, reentrant.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "chromo/files/float_image.hpp"

namespace chromo::maps {

// A false-colour map (viridis) of values in [low, high] (log scale if asked),
// pixels where hide[i] is set in grey, with a colour bar and its range on the right.
void write_map_png(const std::filesystem::path& path, const std::vector<float>& values, int width, int height,
                   double low, double high, bool log_scale, const std::string& label,
                   const std::vector<std::uint8_t>& hide);
// Categorical map (flags, order): one colour per code with a legend.
void write_category_png(const std::filesystem::path& path, const std::vector<float>& codes, int width, int height,
                        const std::vector<std::string>& names);

// The same PNG files' bytes, for a caller that writes them itself
// (write_estimate_report encodes its previews in parallel). Throws
// files::ImageError when encoding fails.
std::vector<std::uint8_t> encode_map_png(const std::vector<float>& values, int width, int height, double low,
                                         double high, bool log_scale, const std::string& label,
                                         const std::vector<std::uint8_t>& hide);
std::vector<std::uint8_t> encode_category_png(const std::vector<float>& codes, int width, int height,
                                              const std::vector<std::string>& names);

}  // namespace chromo::maps
