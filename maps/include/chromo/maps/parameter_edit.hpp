#pragma once
// Editing parameter maps inside a soft mask: the paper's simulated flushing
// (scale Ch and Che in a region, then relight), or any other parameter.
//
// A mask is a float image in [0, 1] of the maps' size. Shapes (ellipse,
// polygon) are rasterised and feathered: the value is 1 deeper than the
// feather radius inside the outline, 0 further than it outside, and ramps
// linearly across the 2·feather band centred on the outline (0.5 on it).
// A mask image file is read as 8- or 16-bit grey, scaled to [0, 1] and
// feathered the same way (by a box-free distance ramp of its 0.5 contour).
//
// A scale factor s applies as p' = p · (1 + m·(s - 1)), so m = 1 scales fully
// and m = 0 leaves the pixel. Results outside MODEL.md's ranges are clamped to
// them and counted. Flagged pixels (flags != 0) are left alone.

#include <opencv2/core.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "chromo/maps/profile_table.hpp"  // ParameterMaps

namespace chromo::maps {

struct EllipseShape {
  double center_x_px = 0, center_y_px = 0;
  double radius_x_px = 0, radius_y_px = 0;
  double angle_deg = 0;
};

struct PolygonShape {
  std::vector<cv::Point2d> vertices_px;  // at least 3
};

// Throw std::invalid_argument naming what is wrong: a degenerate shape, a
// negative feather, or a shape that does not overlap the width × height image.
cv::Mat ellipse_mask(int width, int height, const EllipseShape& ellipse, double feather_px);
cv::Mat polygon_mask(int width, int height, const PolygonShape& polygon, double feather_px);
// Throws std::runtime_error for an unreadable file or a size other than width × height.
cv::Mat read_mask_image(const std::filesystem::path& path, int width, int height, double feather_px);

struct ParameterScale {
  double cm = 1, ch = 1, bm = 1, che = 1;
};

struct EditReport {
  std::size_t pixels_touched = 0;   // mask > 0 and not flagged
  std::size_t values_clamped = 0;   // parameter values pulled back into range
  double clamped_share = 0;         // values_clamped / (4 · pixels_touched)
  std::size_t clamped_cm = 0, clamped_ch = 0, clamped_bm = 0, clamped_che = 0;
};

// Edits maps in place. Throws std::invalid_argument for a mask of another
// size or type, or a non-positive or non-finite factor (nothing is changed).
EditReport scale_parameters(ParameterMaps& maps, const cv::Mat& mask, const ParameterScale& scale);

}  // namespace chromo::maps
