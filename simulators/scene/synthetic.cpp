#include "chromo/simulators/scene/synthetic.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/grid.hpp"

namespace chromo::simulators {

estimation::ChannelNoise CameraNoiseModel::channel_noise() const {
  estimation::ChannelNoise n;
  const double albedo_per_electron = full_scale_albedo / electrons_at_full_scale;
  const double step = full_scale_albedo / 4095.0;
  const double scale = std::max(noise_scale, 1e-3);  // the estimator needs σ > 0 even for noise-free frames
  n.read_sigma = scale * std::sqrt(std::pow(read_noise_electrons * albedo_per_electron, 2) + step * step / 12.0);
  n.shot_coefficient = scale * scale * albedo_per_electron;
  n.saturation_albedo = full_scale_albedo * (4094.5 / 4095.0);
  return n;
}

void set_exposure_noise(estimation::MeasurementSet& set, const CameraNoiseModel& noise) {
  const int count = set.size();
  std::vector<double> white(count);
  for (int c = 0; c < count; ++c)
    white[c] = (set.camera.rgb[set.channels[c].camera_channel] * set.channels[c].illuminant).values().sum();
  const estimation::ChannelNoise base = noise.channel_noise();
  for (int c = 0; c < count; ++c) {
    double brightest = white[c];
    for (int d = 0; d < count; ++d)
      if ((set.channels[d].illuminant.values() == set.channels[c].illuminant.values()).all())
        brightest = std::max(brightest, white[d]);
    const double share = brightest > 0 ? white[c] / brightest : 1.0;
    estimation::ChannelNoise& n = set.channels[c].noise;
    // The method's blue-only channel is the difference of two captures: both read noises.
    const double own_factor = set.channels[c].name == "blue.B" ? std::sqrt(2.0) : 1.0;
    n.read_sigma = base.read_sigma * own_factor / std::max(share, 1e-6);
    n.shot_coefficient = base.shot_coefficient / std::max(share, 1e-6);
    n.saturation_albedo = base.saturation_albedo;
  }
}

std::vector<float> add_channel_noise(std::span<const float> clean, const estimation::MeasurementSet& set,
                                     std::uint64_t seed) {
  const int count = set.size();
  std::vector<float> out(clean.begin(), clean.end());
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const estimation::ChannelNoise& n = set.channels[i % count].noise;
    const double a = clean[i];
    if (!std::isfinite(a)) continue;
    const double v = a + std::sqrt(n.variance(a)) * gauss(rng);
    out[i] = static_cast<float>(std::clamp(v, 0.0, n.saturation_albedo));
  }
  return out;
}

estimation::MeasurementSet capture_measurement_set(
    const spectral::CameraSensitivity& camera,
    const std::vector<std::pair<std::string, spectral::Spectrum>>& captures, const estimation::ChannelNoise& noise) {
  estimation::MeasurementSet set{camera, {}};
  const char* names[3] = {".R", ".G", ".B"};
  for (const auto& [name, illuminant] : captures)
    for (int c = 0; c < 3; ++c) set.channels.push_back({name + names[c], illuminant, c, noise});
  return set;
}

const char* synthetic_kind_name(SyntheticKind kind) {
  constexpr const char* kNames[kSyntheticKindCount] = {"skin", "vein", "tattoo", "marker",
                                                       "specular", "saturated", "dark", "nan"};
  return kNames[static_cast<int>(kind)];
}

std::vector<estimation::SkinParameters> random_skin_parameters(int count, const estimation::SkinParameters& low, const estimation::SkinParameters& high,
                                                   std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto log_uniform = [&](double a, double b) { return a * std::pow(b / a, u(rng)); };
  auto uniform = [&](double a, double b) { return a + (b - a) * u(rng); };
  std::vector<estimation::SkinParameters> out(count);
  for (estimation::SkinParameters& p : out) {
    p.cm = low.cm > 0 ? log_uniform(low.cm, high.cm) : uniform(low.cm, high.cm);
    p.ch = low.ch > 0 ? log_uniform(low.ch, high.ch) : uniform(low.ch, high.ch);
    p.bm = uniform(low.bm, high.bm);
    p.che = uniform(low.che, high.che);
  }
  return out;
}

spectral::GridArray anomaly_albedo_factor(SyntheticKind kind) {
  spectral::GridArray f;
  for (int i = 0; i < spectral::kGridSize; ++i) {
    const double l = spectral::grid_wavelength_nm(i);
    switch (kind) {
      case SyntheticKind::kVein: {
        const double t = std::clamp((l - 520.0) / 120.0, 0.0, 1.0);
        f[i] = 1.0 - 0.45 * t * t * (3 - 2 * t);
        break;
      }
      case SyntheticKind::kTattoo: f[i] = 0.18 + 0.12 * std::exp(-std::pow((l - 460.0) / 50.0, 2)); break;
      case SyntheticKind::kMarker: f[i] = std::pow(0.15 + 0.8 * std::exp(-std::pow((l - 525.0) / 40.0, 2)), 2); break;
      case SyntheticKind::kDark: f[i] = 0.01; break;
      default: f[i] = 1.0;
    }
  }
  return f;
}

SyntheticFrame make_synthetic_frame(estimation::MeasurementSet& set, const SyntheticOptions& options) {
  const estimation::ChannelNoise noise = options.noise.channel_noise();
  for (estimation::MeasurementChannel& c : set.channels) c.noise = noise;
  // The synthesised blue-only channel of the method's set differences two captures.
  for (estimation::MeasurementChannel& c : set.channels)
    if (c.name == "blue.B") c.noise.read_sigma *= std::sqrt(2.0);
  set.validate();

  SyntheticFrame frame;
  const int n = options.pixels;
  const int channels = set.size();
  frame.channels = channels;
  frame.truth = random_skin_parameters(n, options.low, options.high, options.seed);
  frame.kind.assign(n, SyntheticKind::kSkin);
  const bool real_skin = !options.skin_spectra.empty();
  if (real_skin) {
    if (options.patch_pixels < 1) throw std::invalid_argument("synthetic frame: patch_pixels must be >= 1");
    if (!(options.texture_relative >= 0 && options.texture_relative < 1))
      throw std::invalid_argument("synthetic frame: texture_relative must be in [0, 1)");
    const double nan = std::numeric_limits<double>::quiet_NaN();
    frame.spectrum_index.resize(n);
    frame.skin_scale.assign(n, 1.0f);
    for (int i = 0; i < n; ++i) {
      frame.truth[i] = {nan, nan, nan, nan};
      frame.spectrum_index[i] = (i / options.patch_pixels) % static_cast<int>(options.skin_spectra.size());
    }
  }
  {
    std::mt19937_64 rng(options.seed * 7919 + 3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < n; ++i) {
      double r = u(rng);
      for (int k = 1; k < kSyntheticKindCount; ++k) {
        if (r < options.share[k]) {
          frame.kind[i] = static_cast<SyntheticKind>(k);
          break;
        }
        r -= options.share[k];
      }
    }
  }
  const estimation::SkinModel model;
  const Eigen::MatrixXd weights = set.weights();
  std::array<spectral::GridArray, kSyntheticKindCount> factors;
  for (int k = 0; k < kSyntheticKindCount; ++k) factors[k] = anomaly_albedo_factor(static_cast<SyntheticKind>(k));
  frame.clean.resize(static_cast<std::size_t>(n) * channels);
  frame.noisy.resize(frame.clean.size());
  const int thread_count = options.threads > 0 ? options.threads : omp_get_num_procs();
  constexpr int kChunk = 4096;
  const int chunks = (n + kChunk - 1) / kChunk;
#pragma omp parallel for num_threads(thread_count) schedule(dynamic, 1)
  for (int chunk = 0; chunk < chunks; ++chunk) {
    std::mt19937_64 rng(options.seed * 1000003 + chunk);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const int first = chunk * kChunk, last = std::min(n, first + kChunk);
    for (int i = first; i < last; ++i) {
      const SyntheticKind kind = frame.kind[i];
      spectral::GridArray skin;
      if (real_skin) {
        const double scale = 1 + options.texture_relative * (2 * u(rng) - 1);
        frame.skin_scale[i] = static_cast<float>(scale);
        skin = options.skin_spectra[frame.spectrum_index[i]].values() * scale;
      } else {
        skin = model.albedo(frame.truth[i]).values();
      }
      spectral::GridArray albedo = skin * factors[static_cast<int>(kind)];
      if (kind == SyntheticKind::kSpecular) albedo += 0.08 + 0.32 * u(rng);
      Eigen::VectorXd m = weights * albedo.matrix();
      if (kind == SyntheticKind::kSaturated) m *= 1.5 * options.noise.full_scale_albedo / m.maxCoeff();
      const int nan_channel = static_cast<int>(u(rng) * channels);
      for (int c = 0; c < channels; ++c) {
        const std::size_t at = static_cast<std::size_t>(i) * channels + c;
        // The sensor clips after the noise: a channel above full scale stays clipped.
        double clean = std::min(m[c], options.noise.full_scale_albedo);
        double noisy = clean;
        if (options.noise.noise_scale > 0) {
          noisy = m[c] + std::sqrt(set.channels[c].noise.variance(m[c])) * gauss(rng);
          const double step = options.noise.full_scale_albedo / 4095.0;
          noisy = std::clamp(std::round(noisy / step) * step, 0.0, options.noise.full_scale_albedo);
        }
        if (kind == SyntheticKind::kNaN && c == nan_channel)
          clean = noisy = std::numeric_limits<double>::quiet_NaN();
        frame.clean[at] = static_cast<float>(clean);
        frame.noisy[at] = static_cast<float>(noisy);
      }
    }
  }
  return frame;
}

}  // namespace chromo::simulators
