#include "chromo/maps/parameter_edit.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/files/bounded_read.hpp"

namespace chromo::maps {
namespace {

// Turns a hard 0/255 mask into the feathered ramp of the header.
cv::Mat feather(const cv::Mat& hard, double feather_px) {
  if (!(feather_px >= 0.0) || !std::isfinite(feather_px))
    throw std::invalid_argument("feather radius must be ≥ 0 pixels, got " + std::to_string(feather_px));
  cv::Mat mask;
  if (feather_px == 0.0) {
    hard.convertTo(mask, CV_32F, 1.0 / 255.0);
    return mask;
  }
  cv::Mat outside = 255 - hard;
  cv::Mat distance_inside, distance_outside;  // distance to the nearest pixel of the other side
  cv::distanceTransform(hard, distance_inside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::distanceTransform(outside, distance_outside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  // Signed distance to the outline, which lies half way between the last
  // pixel inside and the first outside: + inside, - outside.
  cv::Mat half_pixel(hard.size(), CV_32F, cv::Scalar(0.5f));
  half_pixel.setTo(-0.5f, hard);
  cv::Mat signed_distance = distance_inside - distance_outside + half_pixel;
  signed_distance.convertTo(mask, CV_32F, 1.0 / (2.0 * feather_px), 0.5);
  cv::min(cv::max(mask, 0.0), 1.0, mask);
  return mask;
}

void check_overlap(const cv::Mat& hard, const std::string& what) {
  if (cv::countNonZero(hard) == 0) throw std::invalid_argument(what + " does not overlap the image");
}

}  // namespace

cv::Mat ellipse_mask(int width, int height, const EllipseShape& e, double feather_px) {
  if (!(e.radius_x_px > 0 && e.radius_y_px > 0))
    throw std::invalid_argument("ellipse radii must be > 0 pixels");
  cv::Mat hard = cv::Mat::zeros(height, width, CV_8U);
  cv::ellipse(hard, cv::RotatedRect(cv::Point2f(e.center_x_px, e.center_y_px),
                                    cv::Size2f(2 * e.radius_x_px, 2 * e.radius_y_px), e.angle_deg),
              cv::Scalar(255), cv::FILLED, cv::LINE_8);
  check_overlap(hard, "the ellipse");
  return feather(hard, feather_px);
}

cv::Mat polygon_mask(int width, int height, const PolygonShape& polygon, double feather_px) {
  if (polygon.vertices_px.size() < 3) throw std::invalid_argument("a polygon needs at least 3 vertices");
  std::vector<cv::Point> points;
  for (const auto& v : polygon.vertices_px) {
    if (!std::isfinite(v.x) || !std::isfinite(v.y)) throw std::invalid_argument("polygon vertex is not finite");
    points.emplace_back(static_cast<int>(std::lround(v.x)), static_cast<int>(std::lround(v.y)));
  }
  cv::Mat hard = cv::Mat::zeros(height, width, CV_8U);
  cv::fillPoly(hard, std::vector<std::vector<cv::Point>>{points}, cv::Scalar(255), cv::LINE_8);
  check_overlap(hard, "the polygon");
  return feather(hard, feather_px);
}

cv::Mat read_mask_image(const std::filesystem::path& path, int width, int height, double feather_px) {
  std::string bytes;
  try {
    bytes = files::read_png_file(path);  // a regular PNG file, size checked by header before decoding
  } catch (const files::InputFileError& e) {
    throw std::runtime_error(e.what());
  }
  cv::Mat image;
  try {
    image = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, bytes.data()),
                         cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
  } catch (const cv::Exception&) {
  }
  if (image.empty()) throw std::runtime_error(path.string() + ": not a readable image");
  if (image.cols != width || image.rows != height)
    throw std::runtime_error(path.string() + ": mask is " + std::to_string(image.cols) + "x" +
                             std::to_string(image.rows) + " but the maps are " + std::to_string(width) + "x" +
                             std::to_string(height));
  cv::Mat unit;
  image.convertTo(unit, CV_32F, image.depth() == CV_16U ? 1.0 / 65535.0 : 1.0 / 255.0);
  if (feather_px == 0.0) return unit;
  cv::Mat hard;
  cv::threshold(unit, hard, 0.5, 255, cv::THRESH_BINARY);
  hard.convertTo(hard, CV_8U);
  check_overlap(hard, path.string());
  return feather(hard, feather_px);
}

EditReport scale_parameters(ParameterMaps& maps, const cv::Mat& mask, const ParameterScale& scale) {
  if (mask.type() != CV_32F || mask.cols != maps.width || mask.rows != maps.height)
    throw std::invalid_argument("mask must be a " + std::to_string(maps.width) + "x" + std::to_string(maps.height) +
                                " float image");
  for (double s : {scale.cm, scale.ch, scale.bm, scale.che})
    if (!(s > 0.0) || !std::isfinite(s)) throw std::invalid_argument("scale factors must be finite and > 0");
  EditReport report;
  auto apply = [&report](float& value, double factor, float m, const estimation::ParameterRange& range, std::size_t& counter) {
    if (factor == 1.0) return;
    const double scaled = value * (1.0 + m * (factor - 1.0));
    const double clamped = std::clamp(scaled, range.min, range.max);
    if (clamped != scaled) ++counter, ++report.values_clamped;
    value = static_cast<float>(clamped);
  };
  const std::size_t pixels = static_cast<std::size_t>(maps.width) * maps.height;
  for (std::size_t i = 0; i < pixels; ++i) {
    const float m = mask.ptr<float>()[i];
    if (m <= 0.0f || maps.flags[i] != 0.0f) continue;
    ++report.pixels_touched;
    apply(maps.cm[i], scale.cm, m, estimation::kCmRange, report.clamped_cm);
    apply(maps.ch[i], scale.ch, m, estimation::kChRange, report.clamped_ch);
    apply(maps.bm[i], scale.bm, m, estimation::kBmRange, report.clamped_bm);
    apply(maps.che[i], scale.che, m, estimation::kCheRange, report.clamped_che);
  }
  report.clamped_share =
      report.pixels_touched ? static_cast<double>(report.values_clamped) / (4.0 * report.pixels_touched) : 0.0;
  return report;
}

}  // namespace chromo::maps
