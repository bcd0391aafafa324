// The noise model and measurement set of a measurement's captures
// (method_measurement.hpp "Noise"): each channel's read, shot and white
// noise from the dark and white references, the method's blue-only
// channel, any plan's three channels per capture, and the exposure checks.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "measurement_references.hpp"

namespace chromo::session::measurement {

namespace {

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

}  // namespace

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

}  // namespace chromo::session::measurement
