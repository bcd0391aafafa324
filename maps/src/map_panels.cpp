#include "chromo/maps/map_panels.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "chromo/spectral/srgb.hpp"

namespace chromo::maps {
namespace {
const cv::Vec3b kGrey(128, 128, 128);
const cv::Scalar kBlack(0, 0, 0), kWhite(255, 255, 255);

void text(cv::Mat& canvas, const std::string& s, cv::Point at, double scale = 0.45) {
  cv::putText(canvas, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, kBlack, 1, cv::LINE_AA);
}
std::string format(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", v);
  return buffer;
}
}  // namespace

cv::Mat srgb_preview(const std::vector<float>& linear_rgb, int width, int height, const std::vector<std::uint8_t>& valid) {
  cv::Mat out(height, width, CV_8UC3);
  for (int i = 0; i < width * height; ++i) {
    if (!valid.empty() && !valid[i]) {
      out.at<cv::Vec3b>(i) = kGrey;
      continue;
    }
    auto encode = [&](int c) {
      const double v = linear_rgb[3 * i + c];
      return static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(std::isfinite(v) ? spectral::srgb_encode(std::max(v, 0.0)) : 0.0, 0.0, 1.0)));
    };
    out.at<cv::Vec3b>(i) = cv::Vec3b(encode(2), encode(1), encode(0));  // BGR
  }
  return out;
}

cv::Mat heat_map_with_bar(const std::vector<double>& values, int width, int height, double high, const std::string& label) {
  if (!(high > 0)) high = 1.0;
  cv::Mat grey(height, width, CV_8U);
  for (int i = 0; i < width * height; ++i)
    grey.at<std::uint8_t>(i) = static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(values[i] / high, 0.0, 1.0)));
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_INFERNO);
  for (int i = 0; i < width * height; ++i)
    if (!std::isfinite(values[i])) colour.at<cv::Vec3b>(i) = kGrey;
  constexpr int kBar = 80;
  const int bar_height = std::max(height, 120);
  cv::Mat canvas(bar_height, width + kBar, CV_8UC3, kWhite);
  colour.copyTo(canvas(cv::Rect(0, 0, width, height)));
  const int top = 10, length = bar_height - 20;
  cv::Mat ramp(length, 1, CV_8U);
  for (int y = 0; y < length; ++y) ramp.at<std::uint8_t>(y) = static_cast<std::uint8_t>(255 - 255 * y / std::max(1, length - 1));
  cv::Mat ramp_colour;
  cv::applyColorMap(ramp, ramp_colour, cv::COLORMAP_INFERNO);
  cv::resize(ramp_colour, ramp_colour, cv::Size(16, length), 0, 0, cv::INTER_NEAREST);
  ramp_colour.copyTo(canvas(cv::Rect(width + 8, top, 16, length)));
  for (double f : {0.0, 0.5, 1.0}) {
    const int y = top + static_cast<int>(std::lround((1.0 - f) * (length - 1)));
    cv::line(canvas, {width + 24, y}, {width + 28, y}, kBlack);
    text(canvas, (f == 1.0 ? ">=" : "") + format(f * high), {width + 30, y + 4}, 0.35);
  }
  text(canvas, label, {width + 30, top + length / 2 - 12}, 0.35);
  return canvas;
}

cv::Mat side_by_side(const std::vector<PanelTile>& tiles, const std::string& caption) {
  if (tiles.empty()) throw std::invalid_argument("side_by_side: no tiles");
  constexpr int kGap = 10, kTitle = 24, kCaption = 24;
  int width = kGap, height = 0;
  for (const auto& t : tiles) width += t.image.cols + kGap, height = std::max(height, t.image.rows);
  cv::Mat canvas(kTitle + height + (caption.empty() ? kGap : kCaption), width, CV_8UC3, kWhite);
  int x = kGap;
  for (const auto& t : tiles) {
    t.image.copyTo(canvas(cv::Rect(x, kTitle, t.image.cols, t.image.rows)));
    text(canvas, t.title, {x, kTitle - 8}, 0.5);
    x += t.image.cols + kGap;
  }
  if (!caption.empty()) text(canvas, caption, {kGap, kTitle + height + 17}, 0.45);
  return canvas;
}

void write_png(const std::string& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path, image, {cv::IMWRITE_PNG_COMPRESSION, 6});
  } catch (const cv::Exception&) {
  }
  if (!ok) throw std::runtime_error(path + ": cannot write PNG");
}

}  // namespace chromo::maps
