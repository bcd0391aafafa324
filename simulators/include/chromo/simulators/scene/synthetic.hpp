#pragma once
// Synthetic measurements with known truth, for the estimation tests and the
// bench (the virtual lab's scene in simulators/ replaces this for system
// tests; this one stays small and self-contained).
//
// Camera noise model (12-bit): the raw count of a channel is
//   counts = albedo / full_scale_albedo · 4095,
// with shot noise (Poisson, approximated as Gaussian) of electrons_at_full_scale
// electrons at 4095 counts and Gaussian read noise of read_noise_electrons;
// the result is rounded to whole counts and clipped to 0-4095. In albedo units
// that is σ² = read² + shot·albedo + step²/12 (camera_channel_noise()). A
// synthesised difference channel (the blue-only channel) carries the read
// noise of both captures (estimation::method_measurement_set() doubles its read variance).
//
// Anomalies (per pixel, albedo spectra defined here; see synthetic.cpp):
//   vein      skin · (1 − 0.45·s(λ)), s a smooth step 520→640 nm: a deep
//             absorber seen through the dermis, strongest in the red
//   tattoo    skin · (0.18 + 0.12·exp(−((λ−460)/50)²)): carbon/blue-black ink
//   marker    skin · T(λ)², T = 0.15 + 0.8·exp(−((λ−525)/40)²): green felt pen
//   specular  skin + s, s uniform in [0.08, 0.4]: white surface reflection
//   saturated skin scaled so that its brightest channel is 1.5× full scale (clips)
//   dark      skin · 0.01 (shadow, hair)
//   nan       one channel NaN
// Skin parameters are drawn uniformly in log Cm, log Ch, βm, Che within the
// options' box.

#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::simulators {

struct CameraNoiseModel {
  double full_scale_albedo = 1.25;
  double electrons_at_full_scale = 12000;
  double read_noise_electrons = 6;
  double noise_scale = 1.0;  // multiplies σ (0 = noise-free; bench sweeps it)
  estimation::ChannelNoise channel_noise() const;
};

enum class SyntheticKind : std::uint8_t { kSkin, kVein, kTattoo, kMarker, kSpecular, kSaturated, kDark, kNaN };
inline constexpr int kSyntheticKindCount = 8;
const char* synthetic_kind_name(SyntheticKind kind);

struct SyntheticOptions {
  int pixels = 4096;
  estimation::SkinParameters low{0.005, 0.005, 0.0, 0.0};   // parameter box of the skin pixels
  estimation::SkinParameters high{0.3, 0.2, 1.0, 0.1};
  // Share of pixels of each anomaly kind (indexed by SyntheticKind; kSkin ignored).
  double share[kSyntheticKindCount] = {0, 0, 0, 0, 0, 0, 0, 0};
  CameraNoiseModel noise;
  std::uint64_t seed = 1;
  int threads = 0;
  // Real skin: when not empty, skin pixel i's albedo is the measured spectrum
  // skin_spectra[(i / patch_pixels) % size] × (1 + texture_relative · t_i),
  // t_i uniform in [−1, 1] (a faint texture), instead of the model's albedo of
  // truth[i]; the anomalies act on it as on model skin. truth then holds NaN
  // (real skin has no true parameters; compare with the spectrum's own
  // full-spectrum fit) and SyntheticFrame::spectrum_index says which spectrum.
  std::vector<spectral::Spectrum> skin_spectra;
  int patch_pixels = 1024;
  double texture_relative = 0.03;
};

struct SyntheticFrame {
  int channels = 0;
  std::vector<float> clean;   // pixels × channels, noise-free (anomalies included)
  std::vector<float> noisy;   // with the camera noise model (== clean when noise_scale = 0)
  std::vector<estimation::SkinParameters> truth;  // skin underneath every pixel
  std::vector<SyntheticKind> kind;
  std::vector<int> spectrum_index;  // real skin: the index into skin_spectra; empty for model skin
  std::vector<float> skin_scale;    // real skin: the texture factor (1 + texture_relative · t_i) of each pixel
  std::size_t pixels() const { return truth.size(); }
};

// The factor an anomaly multiplies the skin's albedo by, per wavelength (the
// header's table; 1 for kinds that are not a factor: skin, specular, saturated, NaN).
spectral::GridArray anomaly_albedo_factor(SyntheticKind kind);

// The noise of every channel in `set` is replaced by options.noise's.
SyntheticFrame make_synthetic_frame(estimation::MeasurementSet& set, const SyntheticOptions& options);

// Per-channel camera noise of a plan whose exposure puts each capture's
// brightest white channel at full scale (as an operator sets it; the
// noise's full_scale_albedo is that channel's): a channel that receives the
// share s = W_c / max W of its capture's white signal (W = Σ camera × its
// illuminant; channels with the same illuminant are one capture) has, in
// albedo units, read σ / s and shot coefficient / s. Each channel's noise
// becomes noise.channel_noise() scaled so; the method's difference channel
// ("blue.B", method_measurement_set) gets √2 × the read σ (two captures) and,
// alone with its illuminant, s = 1 (which favours it). Saturation: the noise's.
void set_exposure_noise(estimation::MeasurementSet& set, const CameraNoiseModel& noise);

// `clean` (pixels × set.size()) plus Gaussian noise of each channel's own
// model at the clean value (ChannelNoise::variance), clipped at 0 and at
// the saturation albedo; NaN stays NaN. Deterministic in seed.
std::vector<float> add_channel_noise(std::span<const float> clean, const estimation::MeasurementSet& set,
                                     std::uint64_t seed);

// R, G and B under each named illuminant (a plan's captures), in order:
// "<name>.R", ... Noise: `noise` for every channel.
estimation::MeasurementSet capture_measurement_set(
    const spectral::CameraSensitivity& camera,
    const std::vector<std::pair<std::string, spectral::Spectrum>>& captures, const estimation::ChannelNoise& noise = {});

// Skin parameters drawn as make_synthetic_frame draws them.
std::vector<estimation::SkinParameters> random_skin_parameters(int count, const estimation::SkinParameters& low, const estimation::SkinParameters& high,
                                                   std::uint64_t seed);

}  // namespace chromo::simulators
