// A measurement's white and dark references, albedo and noise model: see
// measurement_references.hpp.
#include "measurement_references.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace chromo::session {

namespace measurement {
namespace {

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
                           const std::vector<std::uint8_t>& mask = {}) {
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

double mean_of(const std::vector<float>& values, const std::vector<std::uint8_t>& mask = {}) {
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < values.size(); ++i)
    if ((mask.empty() || mask[i]) && std::isfinite(values[i])) sum += values[i], ++count;
  return count ? sum / static_cast<double>(count) : 0.0;
}

}  // namespace
}  // namespace measurement

ReferenceFootprint white_reference_footprint(const RgbImage& white, const RgbImage& dark) {
  const std::size_t n = dark.pixels();
  ReferenceFootprint out;
  // The signal summed over R, G, B, and its noise where the white is unlit
  // (the white's and the dark's read noise: twice the dark's variance).
  std::vector<float> signal(n, 0.0f);
  double unlit_variance = 0;
  for (int c = 0; c < 3; ++c) {
    for (std::size_t i = 0; i < n; ++i) signal[i] += white.planes[c][i] - dark.planes[c][i];
    unlit_variance += 2 * measurement::flat_noise_variance(dark.planes[c], dark.width, dark.height);
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
    for (std::size_t i = 0; i < n; ++i) {
      ws[i] = w[i] - d[i];
      if (w[i] >= kRawSaturated) ++clipped;
    }
    if (clipped > n / 1000)
      throw std::invalid_argument("white reference under " + capture.name + ": channel " + kChannelNames[c] + " is at full scale on " +
                                  std::to_string(100.0 * static_cast<double>(clipped) / static_cast<double>(n)) +
                                  "% of its pixels (saturated): shorten the exposure or dim the mix");
    // Over the camera's footprint of the target only: a posed camera sees
    // it in perspective, dark around it.
    out.white_mean[c] = mean_of(ws, interior);
    out.white_variance[c] = flat_noise_variance(w, dark.width, dark.height, interior);
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
constexpr int kClippedMarginPx = 2;
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

// g = t_subject / t_white: the subject's exposure over its white's (1 when
// either is unknown or both are one exposure).
double subject_gain(const IlluminatedCapture& capture) {
  const double w = capture.white.exposure_us, s = capture.subject.exposure_us;
  if (!(w > 0 && s > 0) || std::abs(w - s) <= 1e-6 * std::max(w, s)) return 1.0;
  return s / w;
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
      a[i] = inside[i] && ws[i] > 1e-3f ? static_cast<float>(rho * (s[i] - d[i]) / ws[i]) : kNaN;
      if (s[i] >= kRawSaturated) out.saturated[i] = 1;
    }
  }
  return out;
}

double frames_of(const RgbImage& image) { return std::max<double>(1.0, static_cast<double>(image.frames)); }

// A subject at another exposure than its white: the white's signal is
// scaled by g, checked against the white at a second exposure when the
// capture has one (method_measurement.hpp "Exposure per capture").
ExposureLinearity check_subject_exposure(const IlluminatedCapture& capture, const RgbImage& dark, double tolerance) {
  const double g = subject_gain(capture);
  if (!(g > 0 && g <= kMaxSubjectExposureRatio))
    throw std::invalid_argument("subject under " + capture.name + ": taken at " +
                                std::to_string(capture.subject.exposure_us) + " us, " + std::to_string(g) +
                                " times its white reference's " + std::to_string(capture.white.exposure_us) +
                                " us; the exposure ratio must be in (0, " + std::to_string(kMaxSubjectExposureRatio) + "]");
  ExposureLinearity out{capture.name, g, 0, 0, 0, false};
  if (!capture.white_linearity) return out;
  return check_exposure_linearity(capture, dark, tolerance);
}

// One frame's variance of a capture's albedo (measurement.hpp's model): W the
// white's mean signal, R one frame's read variance, S one frame's shot
// variance of the white, V_w the white mean's variance, N_s subject frames
// at g times the white's exposure:
//   σ²(a) = (R + g·a·S)/(N_s·g²·W²) + a²·V_w/W²,
// the white's a² taken as a/g (a pixel not brighter than the white's signal
// at the subject's exposure has a ≤ 1/g; at g = 1 the a² ≤ a of before).
estimation::ChannelNoise capture_noise(double W, double R, double S, double V_w, double Ns, double g, double rho,
                                       double dark_mean) {
  estimation::ChannelNoise noise;
  noise.read_sigma = std::max(std::sqrt(R / Ns) / (g * W), 1e-5);
  noise.shot_coefficient = (S / Ns + V_w) / (g * W * W);
  noise.saturation_albedo = rho * (1.0 - dark_mean) / (g * W);
  return noise;
}

References references_of(const MethodCaptures& captures) {
  const RgbImage& dark = captures.dark;
  check_image(dark, dark, "dark capture");
  const double rho = captures.white_reflectance;
  if (!(rho > 0 && rho <= 1)) throw std::invalid_argument("white_reflectance: must be in (0, 1]");
  References r;
  for (const auto* capture : {&captures.broadband, &captures.base, &captures.with_blue})
    r.linearity.push_back(check_subject_exposure(*capture, dark, captures.linearity_tolerance));
  r.broadband = reference_of(captures.broadband, dark), r.base = reference_of(captures.base, dark);
  r.with_blue = reference_of(captures.with_blue, dark);
  const double t_mix = captures.with_blue.white.exposure_us, t_base = captures.base.white.exposure_us;
  if (t_mix > 0 && t_base > 0) r.base_to_mix = t_mix / t_base;
  const double s = r.base_to_mix;
  std::array<double, 3> dark_variance{}, dark_mean{}, read_variance{};
  for (int c = 0; c < 3; ++c) {
    dark_variance[c] = flat_noise_variance(dark.planes[c], dark.width, dark.height);
    dark_mean[c] = mean_of(dark.planes[c]);
    read_variance[c] = dark_variance[c] * frames_of(dark);  // one frame's
  }
  // One frame's shot variance of capture k's white in channel c.
  auto white_shot = [&](const Reference& k, const IlluminatedCapture& capture, int c) {
    return std::max(k.white_variance[c] * frames_of(capture.white) - read_variance[c], 0.0);
  };
  auto albedo_noise = [&](const Reference& k, const IlluminatedCapture& capture, int c) {
    return capture_noise(k.white_mean[c], read_variance[c], white_shot(k, capture, c), k.white_variance[c],
                         frames_of(capture.subject), subject_gain(capture), rho, dark_mean[c]);
  };
  const double D = r.with_blue.white_mean[2] - s * r.base.white_mean[2];
  if (!(D > 1e-3))
    throw std::invalid_argument("W57+blue − W57: the white reference's B channel gains " + std::to_string(D) +
                                " of full scale; the blue-only response needs more blue in the W57+blue mix");
  r.set.camera = captures.camera;
  for (int c = 0; c < 3; ++c) {
    r.capture_noise[0][c] = albedo_noise(r.broadband, captures.broadband, c);
    r.capture_noise[1][c] = albedo_noise(r.base, captures.base, c);
    r.capture_noise[2][c] = albedo_noise(r.with_blue, captures.with_blue, c);
    r.set.channels.push_back({"D65'." + std::string(kChannelNames[c]), captures.broadband.illuminant, c,
                              r.capture_noise[0][c]});
  }
  spectral::Spectrum blue_illuminant = captures.with_blue.illuminant - captures.base.illuminant;
  blue_illuminant = spectral::Spectrum(blue_illuminant.values().max(0.0));
  estimation::ChannelNoise blue_noise;
  const double R = read_variance[2];
  // Each subject at g times its white's exposure, on the white's scale: (R + 0.5·g·S)/(N_s·g²).
  const double g_mix = subject_gain(captures.with_blue), g_base = subject_gain(captures.base);
  const double subject_variance =
      (R + 0.5 * g_mix * white_shot(r.with_blue, captures.with_blue, 2)) /
          (frames_of(captures.with_blue.subject) * g_mix * g_mix) +
      s * s * (R + 0.5 * g_base * white_shot(r.base, captures.base, 2)) /
          (frames_of(captures.base.subject) * g_base * g_base);
  blue_noise.read_sigma = std::max(std::sqrt(subject_variance) / D, 1e-5);
  blue_noise.shot_coefficient = (r.with_blue.white_variance[2] + s * s * r.base.white_variance[2]) / (g_mix * D * D);
  blue_noise.saturation_albedo = rho * (1.0 - dark_mean[2]) / (std::max(g_mix, g_base) * D);
  r.set.channels.push_back({"blue.B", blue_illuminant, 2, blue_noise});
  r.set.validate();
  if (captures.broadband_parallel) {
    r.linearity.push_back(check_subject_exposure(*captures.broadband_parallel, dark, captures.linearity_tolerance));
    r.parallel = reference_of(*captures.broadband_parallel, dark);
    r.parallel_green_noise = albedo_noise(*r.parallel, *captures.broadband_parallel, 1);
  }
  return r;
}

// Pixels outside the footprint of any white reference the measurement uses.
void mark_no_reference(MethodMeasurement& m, const std::vector<const Reference*>& references) {
  m.no_reference.assign(static_cast<std::size_t>(m.width) * m.height, 0);
  for (const Reference* reference : references)
    for (std::size_t i = 0; i < m.no_reference.size(); ++i)
      if (!reference->footprint.inside[i]) m.no_reference[i] = 1;
  m.no_reference_pixels = 0;
  for (auto v : m.no_reference) m.no_reference_pixels += v;
}

PlanReferences plan_references_of(const PlanCaptures& captures) {
  const RgbImage& dark = captures.dark;
  check_image(dark, dark, "dark capture");
  const double rho = captures.white_reflectance;
  if (!(rho > 0 && rho <= 1)) throw std::invalid_argument("white_reflectance: must be in (0, 1]");
  if (captures.captures.empty()) throw std::invalid_argument("the plan has no capture of the subject");
  PlanReferences r;
  // The method's noise model (references_of), per capture: one frame's read
  // variance from the averaged dark, the subject's read and shot noise
  // divided by its own frame count, the white's as averaged.
  std::array<double, 3> read_variance{}, dark_mean{};
  for (int c = 0; c < 3; ++c) {
    read_variance[c] = flat_noise_variance(dark.planes[c], dark.width, dark.height) * frames_of(dark);
    dark_mean[c] = mean_of(dark.planes[c]);
  }
  r.set.camera = captures.camera;
  for (const IlluminatedCapture& capture : captures.captures) {
    r.linearity.push_back(check_subject_exposure(capture, dark, captures.linearity_tolerance));
    r.references.push_back(reference_of(capture, dark));
    const Reference& k = r.references.back();
    for (int c = 0; c < 3; ++c) {
      const double R = read_variance[c];
      const double white_shot = std::max(k.white_variance[c] * frames_of(capture.white) - R, 0.0);  // one frame's
      r.set.channels.push_back({capture.name + "." + kChannelNames[c], capture.illuminant, c,
                                capture_noise(k.white_mean[c], R, white_shot, k.white_variance[c],
                                              frames_of(capture.subject), subject_gain(capture), rho, dark_mean[c])});
    }
  }
  r.set.validate();
  return r;
}

}  // namespace measurement

}  // namespace chromo::session
