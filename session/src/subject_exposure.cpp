// Exposure per capture (method_measurement.hpp): the subject's exposure
// ratio metered from its own frame, and the linearity check that lets a
// white reference be scaled by that ratio.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "chromo/session/method_measurement.hpp"

namespace chromo::session {

namespace {

constexpr const char* kExposureChannelNames[3] = {"R", "G", "B"};
constexpr double kLinearityMinSignal = 0.01;  // of full scale, in both whites

std::string format_number(const char* format, double value) {
  char text[48];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

double masked_mean(const std::vector<float>& image, const std::vector<float>& dark,
                   const std::vector<std::uint8_t>& mask) {
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < image.size(); ++i)
    if (mask[i] && std::isfinite(image[i]) && std::isfinite(dark[i])) sum += image[i] - dark[i], ++count;
  return count ? sum / static_cast<double>(count) : 0.0;
}

}  // namespace

ExposureLinearity check_exposure_linearity(const IlluminatedCapture& capture, const RgbImage& dark, double tolerance) {
  if (!capture.white_linearity)
    throw std::invalid_argument("white under " + capture.name + ": no white at a second exposure to check linearity");
  const RgbImage& second = *capture.white_linearity;
  if (second.width != dark.width || second.height != dark.height || capture.white.width != dark.width ||
      capture.white.height != dark.height)
    throw std::invalid_argument("white under " + capture.name + " at a second exposure: its size differs from the dark's");
  const double t_white = capture.white.exposure_us, t_second = second.exposure_us;
  if (!(t_white > 0 && t_second > 0) || std::abs(t_white - t_second) <= 1e-6 * t_white)
    throw std::invalid_argument("white under " + capture.name + ": the linearity check needs two known, different "
                                "exposures (" + format_number("%.1f", t_white) + " us and " +
                                format_number("%.1f", t_second) + " us)");
  if (!(tolerance > 0 && tolerance < 1)) throw std::invalid_argument("linearity_tolerance: must be in (0, 1)");
  const std::vector<std::uint8_t>& interior = white_reference_footprint(capture.white, dark).interior;
  ExposureLinearity out;
  out.capture = capture.name;
  out.subject_exposure_ratio = capture.white.exposure_us > 0 && capture.subject.exposure_us > 0
                                   ? capture.subject.exposure_us / capture.white.exposure_us
                                   : 1.0;
  out.exposure_ratio = t_white / t_second;
  out.checked = true;
  int worst_channel = -1;
  for (int c = 0; c < 3; ++c) {
    const double a = masked_mean(capture.white.planes[c], dark.planes[c], interior);
    const double b = masked_mean(second.planes[c], dark.planes[c], interior);
    if (!(a > kLinearityMinSignal && b > kLinearityMinSignal)) continue;
    const double deviation = a / b / out.exposure_ratio - 1.0;
    if (worst_channel < 0 || std::abs(deviation) > std::abs(out.deviation))
      worst_channel = c, out.deviation = deviation, out.signal_ratio = a / b;
  }
  if (worst_channel < 0)
    throw std::invalid_argument("white under " + capture.name + ": no channel has 1% of full scale at both " +
                                format_number("%.1f", t_white) + " us and " + format_number("%.1f", t_second) +
                                " us; the linearity check needs signal");
  if (std::abs(out.deviation) > tolerance)
    throw std::invalid_argument(
        "subject under " + capture.name + " at " + format_number("%.3f", out.subject_exposure_ratio) +
        "× its white's exposure: the camera is not linear in exposure: the white at " + format_number("%.1f", t_white) +
        " us and " + format_number("%.1f", t_second) + " us gives a signal ratio of " +
        format_number("%.4f", out.signal_ratio) + " in " + kExposureChannelNames[worst_channel] +
        " against the exposure ratio " + format_number("%.4f", out.exposure_ratio) + " (" +
        format_number("%+.2f", 100 * out.deviation) + "%, tolerance " + format_number("%.2f", 100 * tolerance) +
        "%): take the subject at its white's exposure");
  return out;
}

SubjectMeteringResult meter_subject_exposure(const RgbImage& subject, const RgbImage& dark, const SubjectMetering& options,
                                             const std::vector<std::uint8_t>& mask) {
  if (!(options.fill > 0 && options.fill < 1)) throw std::invalid_argument("subject_fill: must be in (0, 1)");
  if (!(options.percentile > 0 && options.percentile <= 1))
    throw std::invalid_argument("subject_percentile: must be in (0, 1]");
  if (!(options.max_ratio >= 1 && options.max_ratio <= kMaxSubjectExposureRatio))
    throw std::invalid_argument("max_subject_exposure_ratio: must be in [1, " +
                                format_number("%g", kMaxSubjectExposureRatio) + "]");
  if (subject.pixels() == 0 || subject.width != dark.width || subject.height != dark.height)
    throw std::invalid_argument("subject metering: the subject frame is empty or its size differs from the dark's");
  if (!mask.empty() && mask.size() != subject.pixels())
    throw std::invalid_argument("subject metering: the mask's size differs from the frame's");
  SubjectMeteringResult out;
  double best_signal = -1, best_dark = 0;
  std::vector<float> values;
  for (int c = 0; c < 3; ++c) {
    values.clear();
    double dark_sum = 0;
    for (std::size_t i = 0; i < subject.pixels(); ++i)
      if ((mask.empty() || mask[i]) && std::isfinite(subject.planes[c][i]))
        values.push_back(subject.planes[c][i]), dark_sum += dark.planes[c][i];
    if (values.empty()) throw std::invalid_argument("subject metering: no pixel to meter (mask empty)");
    const auto at = values.begin() + static_cast<std::ptrdiff_t>(options.percentile * static_cast<double>(values.size() - 1));
    std::nth_element(values.begin(), at, values.end());
    const double dark_level = dark_sum / static_cast<double>(values.size());
    if (*at - dark_level > best_signal) best_signal = *at - dark_level, best_dark = dark_level, out.channel = c, out.level = *at;
  }
  out.capped = !(best_signal > 1e-6) || (options.fill - best_dark) / best_signal > options.max_ratio;
  out.exposure_ratio = subject_exposure_ratio(out.level, best_dark, options.fill, options.max_ratio);
  return out;
}

double subject_exposure_ratio(double level, double dark, double fill, double max_ratio) {
  const double signal = level - dark;
  if (!(signal > 1e-6)) return max_ratio;
  return std::clamp((fill - dark) / signal, 1.0, max_ratio);
}

}  // namespace chromo::session
