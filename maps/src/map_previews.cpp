#include "chromo/maps/map_previews.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "chromo/estimation/skin_parameters.hpp"

namespace chromo::maps {

std::optional<ModelDisplayRange> model_display_range(const std::string& channel) {
  if (channel == "Cm") return ModelDisplayRange{estimation::kCmRange.min, estimation::kCmRange.max, true};
  if (channel == "Ch") return ModelDisplayRange{estimation::kChRange.min, estimation::kChRange.max, true};
  if (channel == "Bm") return ModelDisplayRange{0.0, 1.0, false};
  if (channel == "Che") return ModelDisplayRange{0.0, 0.1, false};
  return std::nullopt;
}

std::optional<std::pair<double, double>> shown_percentile_range(const std::vector<float>& values,
                                                                const std::vector<std::uint8_t>& hide,
                                                                double low_percent, double high_percent) {
  std::vector<float> shown;
  shown.reserve(values.size());
  for (std::size_t i = 0; i < values.size(); ++i)
    if ((hide.empty() || hide[i] == kPreviewShown) && std::isfinite(values[i])) shown.push_back(values[i]);
  if (shown.empty()) return std::nullopt;
  auto at = [&](double percent) {
    const auto rank = static_cast<std::ptrdiff_t>(std::lround(percent / 100.0 * static_cast<double>(shown.size() - 1)));
    std::nth_element(shown.begin(), shown.begin() + rank, shown.end());
    return static_cast<double>(shown[static_cast<std::size_t>(rank)]);
  };
  const double low = at(low_percent), high = at(high_percent);
  if (!(high > low)) return std::nullopt;
  return std::pair{low, high};
}

ScaleBar scale_bar_for(int width_px, double pixel_mm) {
  if (!(pixel_mm > 0) || !std::isfinite(pixel_mm) || width_px < 4) return {};
  const double longest_mm = 0.25 * width_px * pixel_mm;
  double mm = std::pow(10.0, std::floor(std::log10(longest_mm)));
  for (const double step : {5.0, 2.0})
    if (mm * step <= longest_mm * (1 + 1e-9)) {
      mm *= step;
      break;
    }
  return {mm, static_cast<int>(std::lround(mm / pixel_mm))};
}

namespace {

constexpr int kBarWidth = 165;

// The scale bar (scale_bar_for) in the map's bottom-left corner of `canvas`.
void draw_scale_bar(cv::Mat& canvas, int width, int height, double map_pixel_mm) {
  const ScaleBar bar = scale_bar_for(width, map_pixel_mm);
  if (bar.px < 1 || height < 24) return;
  const cv::Rect white(8, height - 12, bar.px, 4);
  cv::rectangle(canvas, white + cv::Point(-1, -1) + cv::Size(2, 2), cv::Scalar(0, 0, 0), cv::FILLED);
  cv::rectangle(canvas, white, cv::Scalar(255, 255, 255), cv::FILLED);
  char text[32];
  std::snprintf(text, sizeof text, "%g mm", bar.mm);
  const cv::Point at(8, height - 16);
  cv::putText(canvas, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(canvas, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

void save(const std::filesystem::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image)) throw files::ImageError(path.string() + ": cannot write PNG");
}

std::vector<std::uint8_t> encode(const cv::Mat& image) {
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", image, bytes)) throw files::ImageError("cannot encode a preview as PNG");
  return bytes;
}

cv::Mat map_canvas(const std::vector<float>& values, int width, int height, double low, double high, bool log_scale,
                   const std::string& label, const std::vector<std::uint8_t>& hide, double map_pixel_mm) {
  auto normalise = [&](double v) {
    if (log_scale) v = std::log(std::max(v, 1e-12));
    const double lo = log_scale ? std::log(low) : low, hi = log_scale ? std::log(high) : high;
    return std::clamp((v - lo) / (hi - lo), 0.0, 1.0);
  };
  const int bar_height = std::max(height, 160);
  cv::Mat gray(height, width, CV_8U);
  for (int i = 0; i < width * height; ++i) gray.at<std::uint8_t>(i) = static_cast<std::uint8_t>(255 * normalise(values[i]) + 0.5);
  cv::Mat colour;
  cv::applyColorMap(gray, colour, cv::COLORMAP_VIRIDIS);
  for (int i = 0; i < width * height; ++i)
    if (!hide.empty() && hide[i] != kPreviewShown)
      colour.at<cv::Vec3b>(i) = hide[i] == kPreviewOutsideField ? cv::Vec3b(0, 0, 0) : cv::Vec3b(150, 150, 150);
  cv::Mat canvas(bar_height, width + kBarWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  colour.copyTo(canvas(cv::Rect(0, 0, width, height)));
  draw_scale_bar(canvas, width, height, map_pixel_mm);
  cv::Mat ramp(bar_height - 40, 1, CV_8U);
  for (int y = 0; y < ramp.rows; ++y) ramp.at<std::uint8_t>(y) = static_cast<std::uint8_t>(255 - 255 * y / std::max(1, ramp.rows - 1));
  cv::Mat ramp_colour;
  cv::applyColorMap(ramp, ramp_colour, cv::COLORMAP_VIRIDIS);
  cv::resize(ramp_colour, ramp_colour, cv::Size(20, ramp.rows), 0, 0, cv::INTER_NEAREST);
  ramp_colour.copyTo(canvas(cv::Rect(width + 10, 20, 20, ramp.rows)));
  auto text = [&](const std::string& s, int y) {
    cv::putText(canvas, s, cv::Point(width + 34, y), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  };
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.4g", high);
  text(buffer, 28);
  std::snprintf(buffer, sizeof buffer, "%.4g", log_scale ? std::sqrt(low * high) : (low + high) / 2);
  text(buffer, 20 + ramp.rows / 2 + 4);
  std::snprintf(buffer, sizeof buffer, "%.4g", low);
  text(buffer, bar_height - 22);
  const auto newline = label.find('\n');
  text(label.substr(0, newline) + (log_scale ? " (log)" : ""), 12);
  if (newline != std::string::npos) text(label.substr(newline + 1), bar_height - 8);
  if (!hide.empty()) {  // the legend of the pixels without colour, in the bar's margin
    cv::rectangle(canvas, cv::Rect(width + 88, 36, 10, 10), cv::Scalar(150, 150, 150), cv::FILLED);
    cv::putText(canvas, "masked", cv::Point(width + 100, 45), cv::FONT_HERSHEY_SIMPLEX, 0.35, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    cv::rectangle(canvas, cv::Rect(width + 88, 52, 10, 10), cv::Scalar(0, 0, 0), cv::FILLED);
    cv::putText(canvas, "no field", cv::Point(width + 100, 61), cv::FONT_HERSHEY_SIMPLEX, 0.35, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  return canvas;
}

cv::Mat category_canvas(const std::vector<float>& codes, int width, int height, const std::vector<std::string>& names) {
  static const cv::Vec3b kColours[] = {{60, 60, 60},   {255, 0, 255}, {0, 255, 255}, {0, 0, 0},
                                       {255, 255, 255}, {255, 0, 0},  {0, 0, 255},   {0, 200, 0},
                                       {128, 128, 128}};
  const int n = static_cast<int>(std::size(kColours));
  const int legend_height = static_cast<int>(names.size()) * 18 + 10;
  cv::Mat canvas(std::max(height, legend_height), width + 190, CV_8UC3, cv::Scalar(255, 255, 255));
  for (int i = 0; i < width * height; ++i) {
    const int code = std::isfinite(codes[i]) ? std::clamp(static_cast<int>(codes[i]), 0, n - 1) : 0;
    canvas.at<cv::Vec3b>(i / width, i % width) = kColours[code];
  }
  for (std::size_t k = 0; k < names.size(); ++k) {
    const int y = 10 + static_cast<int>(k) * 18;
    cv::rectangle(canvas, cv::Rect(width + 8, y, 12, 12), cv::Scalar(kColours[k % n]), cv::FILLED);
    cv::rectangle(canvas, cv::Rect(width + 8, y, 12, 12), cv::Scalar(0, 0, 0), 1);
    cv::putText(canvas, std::to_string(k) + " " + names[k], cv::Point(width + 26, y + 11), cv::FONT_HERSHEY_SIMPLEX,
                0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  return canvas;
}

}  // namespace

void write_map_png(const std::filesystem::path& path, const std::vector<float>& values, int width, int height,
                   double low, double high, bool log_scale, const std::string& label,
                   const std::vector<std::uint8_t>& hide, double map_pixel_mm) {
  save(path, map_canvas(values, width, height, low, high, log_scale, label, hide, map_pixel_mm));
}

void write_category_png(const std::filesystem::path& path, const std::vector<float>& codes, int width, int height,
                        const std::vector<std::string>& names) {
  save(path, category_canvas(codes, width, height, names));
}

std::vector<std::uint8_t> encode_map_png(const std::vector<float>& values, int width, int height, double low,
                                         double high, bool log_scale, const std::string& label,
                                         const std::vector<std::uint8_t>& hide, double map_pixel_mm) {
  return encode(map_canvas(values, width, height, low, high, log_scale, label, hide, map_pixel_mm));
}

std::vector<std::uint8_t> encode_category_png(const std::vector<float>& codes, int width, int height,
                                              const std::vector<std::string>& names) {
  return encode(category_canvas(codes, width, height, names));
}

}  // namespace chromo::maps
