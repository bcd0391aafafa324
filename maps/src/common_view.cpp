#include "chromo/maps/common_view.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "chromo/estimation/pixel_flags.hpp"

namespace chromo::maps {
namespace {

constexpr float kNoReferenceFlag = static_cast<float>(estimation::PixelFlag::kNoReference);

// The largest 8-connected region of cells inside the target's footprint.
std::vector<cv::Point> footprint_contour(const files::FloatImage& maps, const std::string& what) {
  const auto& flags = maps.channel("flags");
  cv::Mat inside(maps.height, maps.width, CV_8U);
  std::size_t count = 0;
  for (int y = 0; y < maps.height; ++y)
    for (int x = 0; x < maps.width; ++x) {
      const bool in = flags[static_cast<std::size_t>(y) * maps.width + x] != kNoReferenceFlag;
      inside.at<std::uint8_t>(y, x) = in ? 255 : 0;
      count += in;
    }
  if (count == 0) throw std::invalid_argument(what + ": no cell sees the white target (all no_reference)");
  // A footprint touching the map's border has no outline there.
  for (int x = 0; x < maps.width; ++x)
    if (inside.at<std::uint8_t>(0, x) || inside.at<std::uint8_t>(maps.height - 1, x))
      throw std::invalid_argument(what + ": the white target reaches the map's top or bottom edge: its corners are not in view");
  for (int y = 0; y < maps.height; ++y)
    if (inside.at<std::uint8_t>(y, 0) || inside.at<std::uint8_t>(y, maps.width - 1))
      throw std::invalid_argument(what + ": the white target reaches the map's left or right edge: its corners are not in view");
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(inside, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  return *std::max_element(contours.begin(), contours.end(),
                           [](const auto& a, const auto& b) { return cv::contourArea(a) < cv::contourArea(b); });
}

// Four rough corners of the contour, clockwise from the top-left.
std::array<cv::Point2d, 4> rough_corners(const std::vector<cv::Point>& contour, const std::string& what) {
  std::vector<cv::Point> hull, quad;
  cv::convexHull(contour, hull);
  const double perimeter = cv::arcLength(hull, true);
  for (double epsilon = 0.01; epsilon < 0.2 && quad.size() != 4; epsilon += 0.005)
    cv::approxPolyDP(hull, quad, epsilon * perimeter, true);
  if (quad.size() != 4)
    throw std::invalid_argument(what + ": the white target's outline is not a quadrilateral (" +
                                std::to_string(quad.size()) + " corners)");
  cv::Point2d centre(0, 0);
  for (const auto& p : quad) centre += cv::Point2d(p) * 0.25;
  std::array<cv::Point2d, 4> corners;
  for (int k = 0; k < 4; ++k) corners[k] = quad[k];
  // Clockwise on the screen (y down) is increasing atan2 angle; start at the top-left.
  std::sort(corners.begin(), corners.end(), [&](const cv::Point2d& a, const cv::Point2d& b) {
    return std::atan2(a.y - centre.y, a.x - centre.x) < std::atan2(b.y - centre.y, b.x - centre.x);
  });
  const auto first = std::min_element(corners.begin(), corners.end(),
                                      [](const cv::Point2d& a, const cv::Point2d& b) { return a.x + a.y < b.x + b.y; });
  std::rotate(corners.begin(), first, corners.end());
  return corners;
}

double distance_to_segment_line(const cv::Point2d& p, const cv::Point2d& a, const cv::Point2d& b, double* along) {
  const cv::Point2d d = b - a;
  const double length = std::hypot(d.x, d.y);
  *along = ((p - a).dot(d)) / (length * length);
  return std::abs(d.x * (p.y - a.y) - d.y * (p.x - a.x)) / length;
}

cv::Point2d intersect(const cv::Vec3d& l, const cv::Vec3d& m) {
  const cv::Vec3d p = l.cross(m);
  return {p[0] / p[2], p[1] / p[2]};
}

}  // namespace

TargetOutline find_target_outline(const files::FloatImage& maps, const std::string& what) {
  const auto contour = footprint_contour(maps, what);
  const auto rough = rough_corners(contour, what);
  cv::Point2d centre(0, 0);
  for (const auto& c : rough) centre += c * 0.25;
  TargetOutline out;
  for (int k = 0; k < 4; ++k) {
    const cv::Point2d a = rough[k], b = rough[(k + 1) % 4];
    std::vector<cv::Point2f> cells;
    for (const auto& p : contour) {
      double along = 0;
      // Cells near the side, away from the corners (rounded by the footprint's threshold).
      if (distance_to_segment_line(p, a, b, &along) < 2.0 && along > 0.1 && along < 0.9) cells.emplace_back(p);
    }
    if (cells.size() < 4)
      throw std::invalid_argument(what + ": side " + std::to_string(k) + " of the white target has too few outline cells (" +
                                  std::to_string(cells.size()) + ")");
    cv::Vec4f line;
    cv::fitLine(cells, line, cv::DIST_HUBER, 0, 0.01, 0.01);
    double nx = -line[1], ny = line[0];                 // a unit normal
    double c = -(nx * line[2] + ny * line[3]);
    if (nx * centre.x + ny * centre.y + c > 0) nx = -nx, ny = -ny, c = -c;  // outwards: the centre negative
    // The outline cells are the last inside cells: the edge lies on average
    // half a cell step beyond them along the normal's larger component.
    const double shift = 0.5 * std::max(std::abs(nx), std::abs(ny));
    c -= shift;
    out.sides[k] = {nx, ny, c};
    for (const auto& p : cells) out.outline[k].emplace_back(p.x + shift * nx, p.y + shift * ny);
  }
  for (int k = 0; k < 4; ++k) out.corners[k] = intersect(out.sides[(k + 3) % 4], out.sides[k]);
  return out;
}

CommonViewMapping map_onto_reference(const TargetOutline& camera, const TargetOutline& reference) {
  std::array<cv::Point2f, 4> from, to;
  for (int k = 0; k < 4; ++k) from[k] = camera.corners[k], to[k] = reference.corners[k];
  CommonViewMapping out;
  out.to_reference = cv::Matx33d(cv::getPerspectiveTransform(from.data(), to.data()));
  double sum_squares = 0;
  for (int k = 0; k < 4; ++k)
    for (const auto& p : camera.outline[k]) {
      const cv::Vec3d q = out.to_reference * cv::Vec3d(p.x, p.y, 1);
      const auto& s = reference.sides[k];
      const double d = std::abs(s[0] * q[0] / q[2] + s[1] * q[1] / q[2] + s[2]);
      sum_squares += d * d;
      out.max_residual_px = std::max(out.max_residual_px, d);
      ++out.outline_cells;
    }
  out.residual_px = out.outline_cells ? std::sqrt(sum_squares / static_cast<double>(out.outline_cells)) : 0.0;
  return out;
}

files::FloatImage resample_into_common_view(const files::FloatImage& maps, const cv::Matx33d& to_reference, int width,
                                            int height) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("common view: empty reference grid");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  files::FloatImage out;
  out.width = width, out.height = height;
  out.channel_names = maps.channel_names;
  for (std::size_t c = 0; c < maps.channels.size(); ++c) {
    const std::string& name = maps.channel_names[c];
    const bool categorical = name == "flags" || name == "order";
    cv::Mat source(maps.height, maps.width, CV_32F, const_cast<float*>(maps.channels[c].data()));
    cv::Mat warped;
    cv::warpPerspective(source, warped, cv::Mat(to_reference), cv::Size(width, height),
                        categorical ? cv::INTER_NEAREST : cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                        name == "flags" ? cv::Scalar(kNoReferenceFlag) : cv::Scalar(nan));
    out.channels.emplace_back(warped.begin<float>(), warped.end<float>());
  }
  // A cell whose value could not be interpolated (a NaN neighbour: outside the target) has none.
  const auto flags_at = std::find(out.channel_names.begin(), out.channel_names.end(), "flags");
  const auto cm_at = std::find(out.channel_names.begin(), out.channel_names.end(), "Cm");
  if (flags_at != out.channel_names.end() && cm_at != out.channel_names.end()) {
    auto& flags = out.channels[flags_at - out.channel_names.begin()];
    const auto& cm = out.channels[cm_at - out.channel_names.begin()];
    for (std::size_t i = 0; i < flags.size(); ++i)
      if (!std::isfinite(cm[i]) && flags[i] == 0) flags[i] = kNoReferenceFlag;
  }
  return out;
}

}  // namespace chromo::maps
