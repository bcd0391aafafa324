// The white references and albedo of a measurement's captures
// (measurement_references.hpp): the target's footprint, each white's mean
// and noise, a capture's albedo on its white, what registration may see.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "chromo/session/albedo.hpp"
#include "measurement_references.hpp"

namespace chromo::session {

namespace measurement {

void check_image(const RgbImage& image, const RgbImage& like, const std::string& what) {
  if (image.width <= 0 || image.height <= 0)
    throw std::invalid_argument(what + ": empty image");
  if (image.width != like.width || image.height != like.height)
    throw std::invalid_argument(what + ": " + std::to_string(image.width) + "×" + std::to_string(image.height) +
                                " pixels, but the dark capture has " + std::to_string(like.width) + "×" +
                                std::to_string(like.height));
  for (const auto& plane : image.planes)
    if (plane.size() != image.pixels()) throw std::invalid_argument(what + ": a colour plane has the wrong size");
}

// Noise variance of a flat image: half the mean squared difference of
// horizontally adjacent finite pixels (both inside `mask` when one is given).
double flat_noise_variance(const std::vector<float>& plane, int width, int height,
                           const std::vector<std::uint8_t>& mask) {
  double sum = 0;
  std::size_t count = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x + 1 < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      if (!mask.empty() && !(mask[i] && mask[i + 1])) continue;
      const double a = plane[i], b = plane[i + 1];
      if (std::isfinite(a) && std::isfinite(b)) sum += (a - b) * (a - b), ++count;
    }
  return count ? sum / (2.0 * static_cast<double>(count)) : 0.0;
}

double mean_of(const std::vector<float>& values, const std::vector<std::uint8_t>& mask) {
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < values.size(); ++i)
    if ((mask.empty() || mask[i]) && std::isfinite(values[i])) sum += values[i], ++count;
  return count ? sum / static_cast<double>(count) : 0.0;
}

}  // namespace measurement

using namespace measurement;

ReferenceFootprint white_reference_footprint(const RgbImage& white, const RgbImage& dark) {
  const std::size_t n = dark.pixels();
  ReferenceFootprint out;
  // The signal summed over R, G, B, and its noise where the white is unlit
  // (the white's and the dark's read noise: twice the dark's variance).
  std::vector<float> signal(n, 0.0f);
  double unlit_variance = 0;
  for (int c = 0; c < 3; ++c) {
    for (std::size_t i = 0; i < n; ++i) signal[i] += white.planes[c][i] - dark.planes[c][i];
    unlit_variance += 2 * flat_noise_variance(dark.planes[c], dark.width, dark.height);
  }
  std::vector<float> finite;
  finite.reserve(n);
  for (float v : signal)
    if (std::isfinite(v)) finite.push_back(v);
  double high = 0;
  if (!finite.empty()) {
    const auto at = finite.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(finite.size() - 1));
    std::nth_element(finite.begin(), at, finite.end());
    high = *at;
  }
  out.threshold = std::max(kFootprintShare * high, kFootprintNoiseSigmas * std::sqrt(unlit_variance));
  out.inside.assign(n, 1);
  // Nothing lit above the noise: the whole frame, as a camera that sees
  // the target everywhere (the white check below then names the capture).
  if (!(high > out.threshold)) {
    out.inside_pixels = n;
    out.interior = out.inside;
    return out;
  }
  for (std::size_t i = 0; i < n; ++i) out.inside[i] = std::isfinite(signal[i]) && signal[i] > out.threshold;
  // The interior: inside pixels whose 8 neighbours are inside too (a
  // footprint's edge pixels see part of the target and part of the dark).
  out.interior.assign(n, 0);
  const int w = dark.width, h = dark.height;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      bool all = true;
      for (int dy = -1; dy <= 1 && all; ++dy)
        for (int dx = -1; dx <= 1 && all; ++dx) {
          const int yy = std::clamp(y + dy, 0, h - 1), xx = std::clamp(x + dx, 0, w - 1);
          all = out.inside[static_cast<std::size_t>(yy) * w + xx] != 0;
        }
      out.interior[static_cast<std::size_t>(y) * w + x] = all;
    }
  for (auto v : out.inside) out.inside_pixels += v;
  return out;
}

namespace measurement {

Reference reference_of(const IlluminatedCapture& capture, const RgbImage& dark) {
  check_image(capture.white, dark, "white reference under " + capture.name);
  const std::size_t n = dark.pixels();
  Reference out;
  out.footprint = white_reference_footprint(capture.white, dark);
  const auto& interior = out.footprint.interior;
  for (int c = 0; c < 3; ++c) {
    const auto &w = capture.white.planes[c], &d = dark.planes[c];
    auto& ws = out.white_signal[c];
    ws.resize(n);
    std::size_t clipped = 0;
    const double scale = capture.white_signal_scale[c];
    for (std::size_t i = 0; i < n; ++i) {
      ws[i] = scale == 1.0 ? w[i] - d[i] : static_cast<float>((w[i] - d[i]) * scale);
      if (w[i] >= kRawSaturated) ++clipped;
    }
    if (clipped > n / 1000)
      throw std::invalid_argument("white reference under " + capture.name + ": channel " + kChannelNames[c] + " is at full scale on " +
                                  std::to_string(100.0 * static_cast<double>(clipped) / static_cast<double>(n)) +
                                  "% of its pixels (saturated): shorten the exposure or dim the mix");
    // Over the camera's footprint of the target only: a posed camera sees
    // it in perspective, dark around it.
    out.white_mean[c] = mean_of(ws, interior);
    out.white_variance[c] = flat_noise_variance(w, dark.width, dark.height, interior) * scale * scale;
    if (!(out.white_mean[c] > 1e-3))
      throw std::invalid_argument("white reference under " + capture.name + ": channel " + kChannelNames[c] +
                                  " is no brighter than the dark capture (white − dark = " +
                                  std::to_string(out.white_mean[c]) + " of full scale)");
  }
  return out;
}

// A plane as registration sees it: the pixels clipped in either capture,
// and their neighbours within kClippedMarginPx, left out (NaN). A clipped
// plateau (a white strip or highlight in view of a subject at g × its
// white's exposure) sits at an albedo set by each capture's g and white, not
// by the scene, and the binned pixels at its edge are clipped in part: both
// pull ECC off (on the daemon's lab, a strip clipped at g = 4.2 and 4.5 gave
// a false shift of 4 px; leaving the clipped pixels alone out, 0.2 px).
static constexpr int kClippedMarginPx = 2;
std::vector<float> unclipped_for_registration(const std::vector<float>& plane, const Normalised& a, const Normalised& b,
                                              int width, int height) {
  std::vector<float> out = plane;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      if (!a.saturated[i] && !b.saturated[i]) continue;
      for (int yy = std::max(0, y - kClippedMarginPx); yy <= std::min(height - 1, y + kClippedMarginPx); ++yy)
        for (int xx = std::max(0, x - kClippedMarginPx); xx <= std::min(width - 1, x + kClippedMarginPx); ++xx)
          out[static_cast<std::size_t>(yy) * width + xx] = kNaN;
    }
  return out;
}

double subject_gain(const IlluminatedCapture& capture) {
  return subject_exposure_gain(capture.white.exposure_us, capture.subject.exposure_us);
}

Normalised normalise(const IlluminatedCapture& capture, const Reference& reference, const RgbImage& dark, double rho) {
  check_image(capture.subject, dark, "subject under " + capture.name);
  rho /= subject_gain(capture);  // the white's signal scaled onto the subject's exposure
  const std::size_t n = dark.pixels();
  Normalised out;
  out.saturated.assign(n, 0);
  for (int c = 0; c < 3; ++c) {
    const auto &s = capture.subject.planes[c], &d = dark.planes[c];
    const auto& ws = reference.white_signal[c];
    auto& a = out.albedo[c];
    a.resize(n);
    const auto& inside = reference.footprint.inside;
    for (std::size_t i = 0; i < n; ++i) {
      a[i] = inside[i] ? albedo(s[i], d[i], ws[i], rho) : kNaN;
      if (s[i] >= kRawSaturated) out.saturated[i] = 1;
    }
  }
  return out;
}

// Pixels outside the footprint of any white reference the measurement uses.
void mark_no_reference(Measurement& m, const std::vector<const Reference*>& references) {
  m.no_reference.assign(static_cast<std::size_t>(m.width) * m.height, 0);
  for (const Reference* reference : references)
    for (std::size_t i = 0; i < m.no_reference.size(); ++i)
      if (!reference->footprint.inside[i]) m.no_reference[i] = 1;
  m.no_reference_pixels = 0;
  for (auto v : m.no_reference) m.no_reference_pixels += v;
}

}  // namespace measurement

}  // namespace chromo::session
