#include "chromo/session/method_measurement.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "chromo/estimation/highlight_flags.hpp"

namespace chromo::session {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kRawSaturated = 0.999f;  // of full scale
constexpr const char* kChannelNames[3] = {"R", "G", "B"};

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

namespace {

struct Reference {  // one illumination's white reference, dark-subtracted
  std::array<std::vector<float>, 3> white_signal;  // white − dark
  std::array<double, 3> white_mean{}, white_variance{};
  ReferenceFootprint footprint;  // where the camera sees the white target
};

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

struct Normalised {
  std::array<std::vector<float>, 3> albedo;  // ρ·(subject − dark)/(white − dark), NaN where white ≤ dark or outside the footprint
  std::vector<std::uint8_t> saturated;       // any raw subject channel at full scale
};

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

struct References {
  Reference broadband, base, with_blue;
  std::optional<Reference> parallel;             // D65' parallel's white
  estimation::ChannelNoise parallel_green_noise;  // its G albedo's noise
  // Each capture's R, G, B albedo noise (the photographs'): D65', W57, W57+blue.
  std::array<std::array<estimation::ChannelNoise, 3>, 3> capture_noise;
  estimation::MeasurementSet set;
  double base_to_mix = 1;  // s = t_mix / t_W57: the W57 capture's signals on the mix's exposure
  std::vector<ExposureLinearity> linearity;  // per capture
};

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

// The variance of a capture's albedo a = ρ·(subject − dark)/(g·(white − dark))
// (measurement.hpp's model): W the white's mean signal, R one frame's read
// variance, S one frame's shot variance of the white (at signal W), V_w the
// white mean's variance, V_d the dark mean's, N_s subject frames at g times
// the white's exposure. The subject's signal at albedo a is g·a·W/ρ, so
//   subject  ρ²·(R + S·g·a/ρ)/(N_s·g²·W²)
//   white    a²·V_w/W²                    (the albedo divides by it per pixel)
//   dark     (a − ρ/g)²·V_d/W²           (subtracted from both)
// → read_sigma² = ρ²·(R/N_s + V_d)/(g²W²), shot_coefficient = ρ·(S/N_s − 2·V_d)/(g·W²)
//   (at least 0), white_coefficient = (V_w + V_d)/W².
// Measured on the lab's skin (bench/noise_model_bench.cpp): the variance of
// noisy − noise-free renders over this model's is ≈ 1 per channel.
estimation::ChannelNoise capture_noise(double W, double R, double S, double V_w, double V_d, double Ns, double g, double rho,
                                       double dark_mean) {
  estimation::ChannelNoise noise;
  noise.read_sigma = std::max(rho * std::sqrt(R / Ns + V_d) / (g * W), 1e-5);
  noise.shot_coefficient = std::max(rho * (S / Ns - 2 * V_d) / (g * W * W), 0.0);
  noise.white_coefficient = (V_w + V_d) / (W * W);
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
                         dark_variance[c], frames_of(capture.subject), subject_gain(capture), rho, dark_mean[c]);
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
  // blue = ρ·(subject_mix − s·subject_W57)/(D per pixel), each subject at g
  // times its white's exposure: the subjects' read noise, their shot noise at
  // the blue albedo a (skin's B albedo under W57 and under W57+blue taken as
  // a: they are the same channel), the two whites' noise relative to D
  // (a²). The dark cancels at s = 1 (the standard plans); at s ≠ 1 its small
  // share is left out.
  const double R = read_variance[2];
  const double g_mix = subject_gain(captures.with_blue), g_base = subject_gain(captures.base);
  const double N_mix = frames_of(captures.with_blue.subject), N_base = frames_of(captures.base.subject);
  blue_noise.read_sigma = std::max(rho * std::sqrt(R / (N_mix * g_mix * g_mix) + s * s * R / (N_base * g_base * g_base)) / D, 1e-5);
  blue_noise.shot_coefficient = rho *
                                (white_shot(r.with_blue, captures.with_blue, 2) / (N_mix * g_mix) +
                                 s * s * white_shot(r.base, captures.base, 2) / (N_base * g_base)) /
                                (D * D);
  blue_noise.white_coefficient = (r.with_blue.white_variance[2] + s * s * r.base.white_variance[2]) / (D * D);
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

struct PlanReferences {
  std::vector<Reference> references;
  std::vector<ExposureLinearity> linearity;  // per capture
  estimation::MeasurementSet set;
};

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
  std::array<double, 3> read_variance{}, dark_variance{}, dark_mean{};
  for (int c = 0; c < 3; ++c) {
    dark_variance[c] = flat_noise_variance(dark.planes[c], dark.width, dark.height);
    read_variance[c] = dark_variance[c] * frames_of(dark);
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
                                capture_noise(k.white_mean[c], R, white_shot, k.white_variance[c], dark_variance[c],
                                              frames_of(capture.subject), subject_gain(capture), rho, dark_mean[c])});
    }
  }
  r.set.validate();
  return r;
}

}  // namespace

estimation::MeasurementSet plan_set_from_references(const PlanCaptures& captures) {
  return plan_references_of(captures).set;
}

MethodMeasurement build_plan_measurement(const PlanCaptures& captures, const RegistrationOptions& options) {
  PlanReferences references = plan_references_of(captures);
  const RgbImage& dark = captures.dark;
  const double rho = captures.white_reflectance;
  const int width = dark.width, height = dark.height;
  const std::size_t n = dark.pixels();
  std::vector<Normalised> normalised;
  for (std::size_t k = 0; k < captures.captures.size(); ++k)
    normalised.push_back(normalise(captures.captures[k], references.references[k], dark, rho));

  MethodMeasurement m;
  m.width = width, m.height = height;
  m.set = std::move(references.set);
  m.linearity = std::move(references.linearity);
  const IlluminatedCapture& first = captures.captures.front();
  // Each capture on its white's brightest channel against the first, the captures at once.
  std::vector<int> channel_of(normalised.size(), 0);
  std::vector<RegistrationPair> pairs;
  for (std::size_t k = 1; k < normalised.size(); ++k) {
    const Reference& reference = references.references[k];
    channel_of[k] = static_cast<int>(std::max_element(reference.white_mean.begin(), reference.white_mean.end()) -
                                     reference.white_mean.begin());
    pairs.push_back({unclipped_for_registration(normalised.front().albedo[channel_of[k]], normalised.front(), normalised[k],
                                                width, height),
                     unclipped_for_registration(normalised[k].albedo[channel_of[k]], normalised.front(), normalised[k],
                                                width, height)});
  }
  const std::vector<RegistrationResult> found = register_channels(pairs, width, height, options);
  pairs.clear();
  for (std::size_t k = 1; k < normalised.size(); ++k) {
    Normalised& moving = normalised[k];
    const int channel = channel_of[k];
    RegistrationResult r = found[k - 1];
    const double motion = corner_displacement_px(r, width, height);
    const bool warped = motion_is_significant(r, motion);
    if (warped) {
      for (auto& plane : moving.albedo) plane = warp_channel(plane, width, height, r);
      std::vector<float> s(moving.saturated.begin(), moving.saturated.end());
      s = warp_channel(s, width, height, r);
      for (std::size_t i = 0; i < n; ++i) moving.saturated[i] = std::isfinite(s[i]) && s[i] > 0;
    }
    m.registration.push_back({"subject under " + captures.captures[k].name, "subject under " + first.name,
                              kChannelNames[channel], r, motion, warped});
  }
  std::vector<const Reference*> used;
  for (const Reference& reference : references.references) used.push_back(&reference);
  mark_no_reference(m, used);
  const int channels = m.set.size();
  m.measured.resize(n * channels);
  for (std::size_t i = 0; i < n; ++i) {
    float* out = &m.measured[i * channels];
    bool saturated = false;
    for (std::size_t k = 0; k < normalised.size(); ++k) {
      for (int c = 0; c < 3; ++c) out[k * 3 + c] = normalised[k].albedo[c][i];
      saturated = saturated || normalised[k].saturated[i];
    }
    if (saturated) {
      ++m.saturated_pixels;
      for (int c = 0; c < channels; ++c)
        if (std::isfinite(out[c]))
          out[c] = std::max(out[c], static_cast<float>(m.set.channels[c].noise.saturation_albedo));
    }
  }
  for (std::size_t k = 0; k < normalised.size(); ++k) {
    const Normalised& a = normalised[k];
    std::array<estimation::ChannelNoise, 3> noise;
    for (int c = 0; c < 3; ++c) noise[c] = m.set.channels[3 * k + c].noise;
    Photograph photo{captures.captures[k].name, captures.captures[k].illuminant, std::vector<Eigen::Vector3d>(n), noise};
    for (std::size_t i = 0; i < n; ++i) photo.rgb[i] = {a.albedo[0][i], a.albedo[1][i], a.albedo[2][i]};
    m.photographs.push_back(std::move(photo));
  }
  m.exposures.push_back({"dark", dark.exposure_us, dark.frames});
  for (const IlluminatedCapture& capture : captures.captures) {
    m.exposures.push_back({"white " + capture.name, capture.white.exposure_us, capture.white.frames});
    m.exposures.push_back({"subject " + capture.name, capture.subject.exposure_us, capture.subject.frames});
  }
  return m;
}

namespace {

// MethodMeasurement::surface (G), surface_red, surface_blue and
// surface_sigma from D65' parallel against the cross D65', pixel by pixel on
// the same grid: not registered. The parallel capture is taken right after
// the cross one (the plan puts it there), and ECC between the two is driven
// by the very highlights that differ between them (on the rendered lab
// session it found 6-7 px of motion where there was none), so a warp would
// do more harm than the subject's motion between two consecutive captures.
// Returns, per channel, where the parallel capture is saturated (its S is a
// lower bound there).
std::array<std::vector<std::uint8_t>, 3> add_surface_map(MethodMeasurement& m, const MethodCaptures& captures,
                                                         const References& references, const Normalised& cross) {
  const IlluminatedCapture& capture = *captures.broadband_parallel;
  const Normalised parallel = normalise(capture, *references.parallel, captures.dark, captures.white_reflectance);
  std::array<double, 3> divisor{2, 2, 2};  // c_parallel − c_cross of ideal films
  if (const auto& factors = captures.surface_factors) {
    auto& correction = m.surface_correction.emplace();
    correction.source = factors->source;
    for (int c = 0; c < 3; ++c) {
      divisor[c] = channel_surface_factor(factors->parallel, captures.camera, capture.illuminant, c) -
                   channel_surface_factor(factors->cross, captures.camera, captures.broadband.illuminant, c);
      if (!(divisor[c] > 0.05))
        throw std::invalid_argument("surface factors (" + factors->source + "): the parallel capture keeps " +
                                    std::to_string(divisor[c]) + " more of the surface light than the cross one in channel " +
                                    kChannelNames[c] + "; films that barely polarise cannot separate it");
      correction.parallel_minus_cross[c] = divisor[c];
    }
  }
  const std::size_t n = cross.albedo[1].size();
  std::array<std::vector<float>*, 3> maps{&m.surface_red, &m.surface, &m.surface_blue};
  std::array<std::vector<std::uint8_t>, 3> saturated;
  for (int c = 0; c < 3; ++c) {
    maps[c]->assign(n, kNaN);
    saturated[c].assign(n, 0);
    const auto &p = parallel.albedo[c], &x = cross.albedo[c];
    const auto& raw = capture.subject.planes[c];
    for (std::size_t i = 0; i < n; ++i) {
      saturated[c][i] = raw[i] >= kRawSaturated;
      if (std::isfinite(p[i]) && std::isfinite(x[i]) && references.parallel->footprint.inside[i])
        (*maps[c])[i] = static_cast<float>((p[i] - x[i]) / divisor[c]);
    }
  }
  const estimation::ChannelNoise& cross_noise = m.set.channels[1].noise;
  m.surface_sigma.assign(n, kNaN);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(m.surface[i])) continue;
    const float p = parallel.albedo[1][i], c = cross.albedo[1][i];
    m.surface_sigma[i] = static_cast<float>(
        std::sqrt(cross_noise.variance(std::max(0.0f, c)) + references.parallel_green_noise.variance(std::max(0.0f, p))) /
        divisor[1]);
  }
  return saturated;
}

double median_of_finite(const std::vector<float>& values) {
  std::vector<float> finite;
  finite.reserve(values.size());
  for (float v : values)
    if (std::isfinite(v)) finite.push_back(v);
  if (finite.empty()) return 0.0;
  const auto middle = finite.begin() + static_cast<std::ptrdiff_t>(finite.size() / 2);
  std::nth_element(finite.begin(), middle, finite.end());
  return *middle;
}

// The cross captures' albedo (D65', and W57 and W57+blue on its grid) less
// the surface light they keep above the sheen's: c_cross,k,c·(S_c − F_c)
// where S_G stands out (SurfaceCorrection). Where the parallel capture is saturated
// in a channel its S_c is a lower bound: that channel takes S_G instead (the
// surface reflection is flat in wavelength to about 1% for η = 1.4).
void remove_surface_light(MethodMeasurement& m, const MethodCaptures& captures,
                          const std::array<std::vector<std::uint8_t>, 3>& parallel_saturated,
                          const std::array<Normalised*, 3>& cross_captures) {
  auto& correction = *m.surface_correction;
  const SurfaceFactors& factors = *captures.surface_factors;
  const std::array<const IlluminatedCapture*, 3> capture_of{&captures.broadband, &captures.base, &captures.with_blue};
  const std::array<const std::vector<float>*, 3> maps{&m.surface_red, &m.surface, &m.surface_blue};
  for (int c = 0; c < 3; ++c) {
    correction.sheen_reference[c] = std::min(median_of_finite(*maps[c]), estimation::kSheenAtNormal);
    for (int k = 0; k < 3; ++k)
      correction.cross_factor[k][c] = channel_surface_factor(factors.cross, captures.camera, capture_of[k]->illuminant, c);
  }
  const std::size_t n = m.surface.size();
  for (std::size_t i = 0; i < n; ++i) {
    const float g = m.surface[i];
    const bool significant = std::isfinite(g) && g - correction.sheen_reference[1] >= kSurfaceCorrectionSigmas * m.surface_sigma[i];
    if (!significant) continue;
    ++correction.corrected_pixels;
    for (int c = 0; c < 3; ++c) {
      const double surface = parallel_saturated[c][i] || !std::isfinite((*maps[c])[i]) ? g : (*maps[c])[i];
      const double excess = surface - correction.sheen_reference[c];
      for (int k = 0; k < 3; ++k) {
        float& a = cross_captures[k]->albedo[c][i];
        if (std::isfinite(a)) a -= static_cast<float>(correction.cross_factor[k][c] * excess);
      }
    }
  }
}

}  // namespace

estimation::MeasurementSet method_set_from_references(const MethodCaptures& captures) { return references_of(captures).set; }

MethodMeasurement build_method_measurement(const MethodCaptures& captures, const RegistrationOptions& options) {
  References references = references_of(captures);
  const RgbImage& dark = captures.dark;
  const double rho = captures.white_reflectance;
  const int width = dark.width, height = dark.height;
  const std::size_t n = dark.pixels();
  Normalised broadband = normalise(captures.broadband, references.broadband, dark, rho);
  Normalised base = normalise(captures.base, references.base, dark, rho);
  Normalised with_blue = normalise(captures.with_blue, references.with_blue, dark, rho);

  MethodMeasurement m;
  m.width = width, m.height = height;
  m.set = std::move(references.set);
  m.linearity = std::move(references.linearity);
  // Register W57 and W57+blue to D65' on the G albedo (both at once), warp all their planes.
  std::vector<RegistrationPair> pairs;
  for (const Normalised* moving : {&base, &with_blue})
    pairs.push_back({unclipped_for_registration(broadband.albedo[1], broadband, *moving, width, height),
                     unclipped_for_registration(moving->albedo[1], broadband, *moving, width, height)});
  const std::vector<RegistrationResult> found = register_channels(pairs, width, height, options);
  pairs.clear();
  for (auto* moving : {&base, &with_blue}) {
    const IlluminatedCapture& capture = moving == &base ? captures.base : captures.with_blue;
    RegistrationResult r = found[moving == &base ? 0 : 1];
    const double motion = corner_displacement_px(r, width, height);
    const bool warped = motion_is_significant(r, motion);
    if (warped) {
      for (auto& plane : moving->albedo) plane = warp_channel(plane, width, height, r);
      std::vector<float> s(moving->saturated.begin(), moving->saturated.end());
      s = warp_channel(s, width, height, r);
      for (std::size_t i = 0; i < n; ++i) moving->saturated[i] = std::isfinite(s[i]) && s[i] > 0;
    }
    m.registration.push_back(
        {"subject under " + capture.name, "subject under " + captures.broadband.name, "G", r, motion, warped});
  }

  mark_no_reference(m, {&references.broadband, &references.base, &references.with_blue});
  // The photographs (what the relit comparison is against) as captured.
  const std::pair<const Normalised*, const IlluminatedCapture*> photographed[] = {
      {&broadband, &captures.broadband}, {&base, &captures.base}, {&with_blue, &captures.with_blue}};
  for (std::size_t p = 0; p < std::size(photographed); ++p) {
    const auto& [k, capture] = photographed[p];
    Photograph photo{capture->name, capture->illuminant, std::vector<Eigen::Vector3d>(n), references.capture_noise[p]};
    for (std::size_t i = 0; i < n; ++i) photo.rgb[i] = {k->albedo[0][i], k->albedo[1][i], k->albedo[2][i]};
    m.photographs.push_back(std::move(photo));
  }
  if (captures.broadband_parallel) {
    const auto parallel_saturated = add_surface_map(m, captures, references, broadband);
    if (captures.surface_factors) remove_surface_light(m, captures, parallel_saturated, {&broadband, &base, &with_blue});
  }
  const int channels = m.set.size();
  m.measured.resize(n * channels);
  for (std::size_t i = 0; i < n; ++i) {
    float* out = &m.measured[i * channels];
    for (int c = 0; c < 3; ++c) out[c] = broadband.albedo[c][i];
    const float wm = references.with_blue.white_signal[2][i];
    const float wb = references.base_to_mix == 1 ? references.base.white_signal[2][i]
                                                 : static_cast<float>(references.base_to_mix * references.base.white_signal[2][i]);
    const float difference = wm - wb;
    out[3] = difference > 1e-3f ? (with_blue.albedo[2][i] * wm - base.albedo[2][i] * wb) / difference : kNaN;
    if (broadband.saturated[i] || base.saturated[i] || with_blue.saturated[i]) {
      ++m.saturated_pixels;
      for (int c = 0; c < channels; ++c)
        if (std::isfinite(out[c]))
          out[c] = std::max(out[c], static_cast<float>(m.set.channels[c].noise.saturation_albedo));
    }
  }

  m.exposures.push_back({"dark", dark.exposure_us, dark.frames});
  for (const IlluminatedCapture* capture : {&captures.broadband, &captures.base, &captures.with_blue}) {
    m.exposures.push_back({"white " + capture->name, capture->white.exposure_us, capture->white.frames});
    m.exposures.push_back({"subject " + capture->name, capture->subject.exposure_us, capture->subject.frames});
  }
  if (const auto& parallel = captures.broadband_parallel) {
    m.exposures.push_back({"white " + parallel->name, parallel->white.exposure_us, parallel->white.frames});
    m.exposures.push_back({"subject " + parallel->name, parallel->subject.exposure_us, parallel->subject.frames});
  }
  return m;
}

}  // namespace chromo::session
