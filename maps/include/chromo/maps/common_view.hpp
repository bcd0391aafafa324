#pragma once
// One view for every camera (issue 42 part 2): each camera's maps resampled
// into one reference camera's map grid through a homography estimated from
// the white reference target every camera sees.
//
// The target: in a camera's maps the cells outside its footprint of the
// white target are flagged no_reference (session/method_measurement.hpp,
// white_reference_footprint). The footprint's outline is a quadrilateral
// (the planar target in perspective); each side is a line fitted to the
// outline's cells (cv::fitLine, moved half a cell outwards to the edge
// between inside and outside cells), the corners where the lines meet. The
// homography camera → reference comes from the four corner pairs
// (cv::getPerspectiveTransform); its residual is the RMS distance, in
// reference cells, of the camera's outline cells mapped into the reference
// from the reference's own side lines (what four exact corners cannot show).
//
// Coordinates: map cells, (0, 0) the first cell's centre (OpenCV's warp
// convention). Pure functions on values; errors as std::invalid_argument
// naming the camera's maps.

#include <opencv2/core.hpp>

#include <array>
#include <string>
#include <vector>

#include "chromo/files/float_image.hpp"

namespace chromo::maps {

// The white target's outline in one camera's maps.
struct TargetOutline {
  std::array<cv::Point2d, 4> corners;                // clockwise from the top-left, cells
  std::array<cv::Vec3d, 4> sides;                    // side k from corner k to k+1: a·x + b·y + c = 0, (a,b) unit, outwards
  std::array<std::vector<cv::Point2d>, 4> outline;   // the outline cells each side was fitted to (edge-corrected)
};

// The outline of the cells not flagged no_reference in `maps` (its "flags"
// channel). Throws std::invalid_argument when the target fills the whole
// map (no outline to find) or its outline is not a quadrilateral, naming
// `what`.
TargetOutline find_target_outline(const files::FloatImage& maps, const std::string& what);

// A camera's place in the common view.
struct CommonViewMapping {
  cv::Matx33d to_reference = cv::Matx33d::eye();  // reference cell ~ H · (camera cell, 1)
  double residual_px = 0;                         // RMS, reference cells
  double max_residual_px = 0;
  std::size_t outline_cells = 0;                  // cells the residual is over
};

// The homography of `camera`'s outline onto `reference`'s (corner to corner)
// and its residual (outline cells against the reference's side lines).
CommonViewMapping map_onto_reference(const TargetOutline& camera, const TargetOutline& reference);

// `maps` resampled into a width × height grid through `to_reference`: every
// channel bilinearly except "flags" and "order" (nearest cell); a cell that
// sees no cell of `maps` (or a NaN one) gets NaN, and flags no_reference.
// The σ channels are resampled as values (an interpolated value's σ is at
// most the larger of its neighbours').
files::FloatImage resample_into_common_view(const files::FloatImage& maps, const cv::Matx33d& to_reference, int width,
                                            int height);

}  // namespace chromo::maps
