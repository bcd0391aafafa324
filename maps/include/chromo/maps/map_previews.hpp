#pragma once
// Preview PNGs of parameter maps (OpenCV): false colour with a colour bar, or
// categories with a legend. Errors throw files::ImageError naming the file.
// Thread rules: free functions, reentrant.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <utility>
#include <string>
#include <vector>

#include "chromo/files/float_image.hpp"

namespace chromo::maps {

// The model's range of a parameter channel as the previews and the web view
// draw it by default: Cm and Ch over the model's bounds on a log scale, Bm
// 0-1, Che 0-0.1; nullopt for a channel with no model range.
struct ModelDisplayRange {
  double low = 0, high = 1;
  bool log_scale = false;
};
std::optional<ModelDisplayRange> model_display_range(const std::string& channel);

// The [low_percent, high_percent] percentiles (nearest rank) of the finite
// values whose hide code is kPreviewShown: a subject's contrast (the
// previews use 1-99). nullopt when no value is shown or the two are equal.
std::optional<std::pair<double, double>> shown_percentile_range(const std::vector<float>& values,
                                                                const std::vector<std::uint8_t>& hide,
                                                                double low_percent, double high_percent);

// Codes of a preview's `hide` vector: which pixels are not drawn in colour.
inline constexpr std::uint8_t kPreviewShown = 0;
inline constexpr std::uint8_t kPreviewMasked = 1;        // a flag other than explained/specular: grey
inline constexpr std::uint8_t kPreviewOutsideField = 2;  // no value or no_reference: black

// A scale bar on a map of `width_px` pixels of `pixel_mm` each: the
// longest 1-2-5 × 10^k mm no longer than a quarter of the map's width, and
// its length in map pixels (round(mm / pixel_mm)); {0, 0} when pixel_mm is
// not > 0. The web view's explorer chooses its bar the same way.
struct ScaleBar {
  double mm = 0;
  int px = 0;
};
ScaleBar scale_bar_for(int width_px, double pixel_mm);

// A false-colour map (viridis) of values in [low, high] (log scale if asked),
// hidden pixels grey (masked) or black (outside the field, hide code 2), with
// a colour bar, its ends and middle value, the label (a second line after
// '\n', e.g. the unit) and the legend of grey and black on the right; with
// map_pixel_mm > 0 (the subject's size of one map pixel) a scale bar in the
// map's bottom-left corner: scale_bar_for's length in white with a black
// edge, 4 pixels high, its bottom 8 pixels above the map's, labelled in mm.
void write_map_png(const std::filesystem::path& path, const std::vector<float>& values, int width, int height,
                   double low, double high, bool log_scale, const std::string& label,
                   const std::vector<std::uint8_t>& hide, double map_pixel_mm = 0);
// Categorical map (flags, order): one colour per code with a legend.
void write_category_png(const std::filesystem::path& path, const std::vector<float>& codes, int width, int height,
                        const std::vector<std::string>& names);

// The same PNG files' bytes, for a caller that writes them itself
// (write_estimate_report encodes its previews in parallel). Throws
// files::ImageError when encoding fails.
std::vector<std::uint8_t> encode_map_png(const std::vector<float>& values, int width, int height, double low,
                                         double high, bool log_scale, const std::string& label,
                                         const std::vector<std::uint8_t>& hide, double map_pixel_mm = 0);
std::vector<std::uint8_t> encode_category_png(const std::vector<float>& codes, int width, int height,
                                              const std::vector<std::string>& names);

}  // namespace chromo::maps
