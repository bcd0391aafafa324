#pragma once
// Statistics of one map channel inside a rectangle of map pixels: what the
// web view's map explorer shows for a drawn region, what `chromo maps stats`
// prints and MapsService.GetRegionStatistics answers (one computation, so
// automation gets the numbers the page shows). Skin pixels only: a pixel
// counts when its value is finite and, for a parameter channel of a file with
// a "flags" channel, its flag is explained or specular (the pixels the
// previews colour); flagged pixels and pixels outside the lit field (NaN or
// no_reference) are counted apart.
// Thread rules: free functions, reentrant.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "chromo/files/float_image.hpp"

namespace chromo::maps {

// [x, x + width) × [y, y + height) in map pixels (maps.exr's own grid).
struct PixelRectangle {
  int x = 0, y = 0, width = 0, height = 0;
};

// "x,y,width,height" (integers). std::invalid_argument naming `field` when
// the text is not four integers or the size is not positive.
PixelRectangle parse_pixel_rectangle(const std::string& text, const std::string& field);

struct RegionStatistics {
  std::string channel, unit;            // unit: map_channel_info's ("" when unknown)
  PixelRectangle region;
  std::int64_t region_pixels = 0;       // width × height
  std::int64_t pixels = 0;              // counted: the statistics are over these
  std::int64_t flagged_pixels = 0;      // a flag other than explained/specular (masked)
  std::int64_t outside_field_pixels = 0;  // NaN or flag no_reference: no measurement there
  // Over the counted values, in double; NaN when none is counted. sd: the
  // sample standard deviation (n − 1; 0 for one pixel). Percentiles by linear
  // interpolation between closest ranks (numpy's default, "linear").
  double mean = 0, sd = 0, min = 0, max = 0;
  double p1 = 0, p5 = 0, p25 = 0, median = 0, p75 = 0, p95 = 0, p99 = 0;
};

// Percentile `percent` (0-100) of ascending values by linear interpolation;
// NaN for an empty list.
double percentile_of_sorted(const std::vector<double>& sorted, double percent);

// The statistics of `channel` of `maps` inside `region`. std::invalid_argument
// starting "channel: " when the image has no such channel, "region: " when
// the rectangle is not inside the image (naming both sizes).
RegionStatistics region_statistics(const files::FloatImage& maps, const std::string& channel,
                                   const PixelRectangle& region);

// Statistics as CSV: a header line, then one row each, values printed to
// round-trip exactly (the columns the page's CSV export has too).
std::string region_statistics_csv(const std::vector<RegionStatistics>& rows);

}  // namespace chromo::maps
