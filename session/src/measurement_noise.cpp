// The noise model and measurement set of a measurement's captures
// (method_measurement.hpp "Noise"): each channel's read, shot and white
// noise from the dark and white references, for the recipe's channels (a
// capture's albedo, or a difference: the standard plan's blue-only), and the
// exposure checks.
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

// The per-frame noise of the dark (measurement_noise's R, V_d) per channel.
struct DarkNoise {
  std::array<double, 3> variance{}, mean{}, read_variance{};
};

DarkNoise dark_noise(const RgbImage& dark) {
  DarkNoise d;
  for (int c = 0; c < 3; ++c) {
    d.variance[c] = flat_noise_variance(dark.planes[c], dark.width, dark.height);
    d.mean[c] = mean_of(dark.planes[c]);
    d.read_variance[c] = d.variance[c] * frames_of(dark);  // one frame's
  }
  return d;
}

// One frame's shot variance of a capture's white in channel c.
double white_shot(const Reference& k, const IlluminatedCapture& capture, const DarkNoise& dark, int c) {
  return std::max(k.white_variance[c] * frames_of(capture.white) - dark.read_variance[c], 0.0);
}

// A capture's albedo noise in channel c (capture_noise above).
estimation::ChannelNoise albedo_noise(const Reference& k, const IlluminatedCapture& capture, const DarkNoise& dark, int c,
                                      double rho) {
  return capture_noise(k.white_mean[c], dark.read_variance[c], white_shot(k, capture, dark, c), k.white_variance[c],
                       dark.variance[c], frames_of(capture.subject), subject_gain(capture), rho, dark.mean[c]);
}

// A difference channel (ChannelRecipe::less): a = ρ·(subject_a − s·subject_b)/(D
// per pixel), each subject at g times its white's exposure, s = t_a/t_b of
// the whites: the subjects' read noise, their shot noise at the difference's
// albedo a (skin's albedo under both taken as a: they are the same camera
// channel), the two whites' noise relative to D (a²). The dark cancels at
// s = 1 (the standard plans); at s ≠ 1 its small share is left out.
estimation::MeasurementChannel difference_channel(const ChannelRecipe& recipe, const Captures& captures,
                                                  const References& r, const DarkNoise& dark, double s) {
  const IlluminatedCapture &a = captures.captures[recipe.capture], &b = captures.captures[*recipe.less];
  const Reference &ka = r.references[recipe.capture], &kb = r.references[*recipe.less];
  const int c = recipe.camera_channel;
  const double D = ka.white_mean[c] - s * kb.white_mean[c];
  if (!(D > 1e-3))
    throw std::invalid_argument(a.name + " − " + b.name + ": the white reference's " + kChannelNames[c] + " channel gains " +
                                std::to_string(D) + " of full scale; the " + recipe.name + "-only response needs more " +
                                recipe.name + " in the " + a.name + " mix");
  const double rho = captures.white_reflectance, R = dark.read_variance[c];
  const double g_a = subject_gain(a), g_b = subject_gain(b);
  const double N_a = frames_of(a.subject), N_b = frames_of(b.subject);
  estimation::ChannelNoise noise;
  noise.read_sigma = std::max(rho * std::sqrt(R / (N_a * g_a * g_a) + s * s * R / (N_b * g_b * g_b)) / D, 1e-5);
  noise.shot_coefficient =
      rho * (white_shot(ka, a, dark, c) / (N_a * g_a) + s * s * white_shot(kb, b, dark, c) / (N_b * g_b)) / (D * D);
  noise.white_coefficient = (ka.white_variance[c] + s * s * kb.white_variance[c]) / (D * D);
  noise.saturation_albedo = rho * (1.0 - dark.mean[c]) / (std::max(g_a, g_b) * D);
  spectral::Spectrum illuminant = a.illuminant - b.illuminant;
  illuminant = spectral::Spectrum(illuminant.values().max(0.0));
  return {recipe.name + "." + kChannelNames[c], illuminant, c, noise};
}

}  // namespace

std::vector<ChannelRecipe> recipe_channels(const Captures& captures) {
  const std::size_t n = captures.captures.size();
  if (captures.recipe.channels.empty()) {
    std::vector<ChannelRecipe> every;
    for (std::size_t k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c) every.push_back({k, c, std::nullopt, {}});
    return every;
  }
  for (std::size_t j = 0; j < captures.recipe.channels.size(); ++j) {
    const ChannelRecipe& recipe = captures.recipe.channels[j];
    if (recipe.capture >= n || (recipe.less && *recipe.less >= n) || recipe.camera_channel < 0 || recipe.camera_channel > 2)
      throw std::invalid_argument("measurement recipe channel " + std::to_string(j) + ": names capture " +
                                  std::to_string(recipe.capture) + " channel " + std::to_string(recipe.camera_channel) +
                                  " of " + std::to_string(n) + " captures with R, G, B");
  }
  return captures.recipe.channels;
}

References references_of(const Captures& captures) {
  const RgbImage& dark = captures.dark;
  check_image(dark, dark, "dark capture");
  const double rho = captures.white_reflectance;
  if (!(rho > 0 && rho <= 1)) throw std::invalid_argument("white_reflectance: must be in (0, 1]");
  if (captures.captures.empty()) throw std::invalid_argument("the plan has no capture of the subject");
  const std::vector<ChannelRecipe> channels = recipe_channels(captures);
  References r;
  for (const IlluminatedCapture& capture : captures.captures)
    r.linearity.push_back(check_subject_exposure(capture, dark, captures.linearity_tolerance));
  for (const IlluminatedCapture& capture : captures.captures) r.references.push_back(reference_of(capture, dark));
  const DarkNoise noise = dark_noise(dark);
  for (std::size_t k = 0; k < captures.captures.size(); ++k) {
    auto& capture_noise = r.capture_noise.emplace_back();
    for (int c = 0; c < 3; ++c) capture_noise[c] = albedo_noise(r.references[k], captures.captures[k], noise, c, rho);
  }
  r.set.camera = captures.camera;
  for (const ChannelRecipe& recipe : channels) {
    const IlluminatedCapture& capture = captures.captures[recipe.capture];
    double s = 1;
    if (!recipe.less) {
      r.set.channels.push_back({capture.name + "." + kChannelNames[recipe.camera_channel], capture.illuminant,
                                recipe.camera_channel, r.capture_noise[recipe.capture][recipe.camera_channel]});
    } else {
      const double t_a = capture.white.exposure_us, t_b = captures.captures[*recipe.less].white.exposure_us;
      if (t_a > 0 && t_b > 0) s = t_a / t_b;
      r.set.channels.push_back(difference_channel(recipe, captures, r, noise, s));
    }
    r.less_scale.push_back(s);
  }
  r.set.validate();
  if (const auto& parallel = captures.parallel) {
    r.linearity.push_back(check_subject_exposure(*parallel, dark, captures.linearity_tolerance));
    r.parallel = reference_of(*parallel, dark);
    r.parallel_green_noise = albedo_noise(*r.parallel, *parallel, noise, 1, rho);
  }
  return r;
}

}  // namespace chromo::session::measurement
