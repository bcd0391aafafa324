#pragma once
// The white and dark references of a measurement's captures and what is
// made from them (method_measurement.hpp), shared by the measurement
// builders (measurement_builders.cpp), the noise model
// (measurement_noise.cpp) and the polarised surface correction
// (measurement_surface.cpp): per illumination the dark-subtracted white
// signal, its mean, noise and footprint; a capture's albedo
// ρ/g·(subject − dark)/(white − dark). Internal to session/ (namespace
// measurement); pure functions, std::invalid_argument naming the capture
// for captures that cannot be used.

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "chromo/session/method_measurement.hpp"

namespace chromo::session::measurement {

inline constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
inline constexpr float kRawSaturated = 0.999f;  // of full scale
inline constexpr const char* kChannelNames[3] = {"R", "G", "B"};

// Throws std::invalid_argument naming `what` when `image` is empty, not the
// size of `like` or has a plane of the wrong size.
void check_image(const RgbImage& image, const RgbImage& like, const std::string& what);

// Noise variance of a flat image: half the mean squared difference of
// horizontally adjacent finite pixels (both inside `mask` when one is given).
double flat_noise_variance(const std::vector<float>& plane, int width, int height,
                           const std::vector<std::uint8_t>& mask = {});

// The mean of the finite values (inside `mask` when one is given); 0 for none.
double mean_of(const std::vector<float>& values, const std::vector<std::uint8_t>& mask = {});

// How many frames an image is the mean of (at least 1).
inline double frames_of(const RgbImage& image) { return std::max<double>(1.0, static_cast<double>(image.frames)); }

// g = t_subject / t_white: the subject's exposure over its white's (1 when
// either is unknown or both are one exposure).
double subject_gain(const IlluminatedCapture& capture);

struct Reference {  // one illumination's white reference, dark-subtracted
  std::array<std::vector<float>, 3> white_signal;  // white − dark
  std::array<double, 3> white_mean{}, white_variance{};
  ReferenceFootprint footprint;  // where the camera sees the white target
};

// The white reference of one capture (its footprint, mean and noise);
// refuses a saturated white or one no brighter than the dark.
Reference reference_of(const IlluminatedCapture& capture, const RgbImage& dark);

struct Normalised {
  std::array<std::vector<float>, 3> albedo;  // ρ·(subject − dark)/(white − dark), NaN where white ≤ dark or outside the footprint
  std::vector<std::uint8_t> saturated;       // any raw subject channel at full scale
};

// A capture's albedo on its white reference: ρ/g·(subject − dark)/(white − dark)
// inside the reference's footprint (g: subject_gain).
Normalised normalise(const IlluminatedCapture& capture, const Reference& reference, const RgbImage& dark, double rho);

// A plane as registration sees it: the pixels clipped in either capture,
// and their neighbours within 2 px, left out (NaN).
std::vector<float> unclipped_for_registration(const std::vector<float>& plane, const Normalised& a, const Normalised& b,
                                              int width, int height);

// Pixels outside the footprint of any white reference the measurement uses
// (Measurement::no_reference).
void mark_no_reference(Measurement& m, const std::vector<const Reference*>& references);

struct References {
  std::vector<Reference> references;  // per capture
  // Each capture's R, G, B albedo noise (its albedo channels' and photograph's).
  std::vector<std::array<estimation::ChannelNoise, 3>> capture_noise;
  std::optional<Reference> parallel;              // the parallel capture's white
  estimation::ChannelNoise parallel_green_noise;  // its G albedo's noise
  estimation::MeasurementSet set;                 // the recipe's channels
  // Per recipe channel: s = t_capture / t_less of the whites (a difference
  // channel's `less` signals on its capture's exposure); 1 for albedo channels.
  std::vector<double> less_scale;
  std::vector<ExposureLinearity> linearity;  // per capture, the parallel one last
};

// The captures' references and measurement set (the recipe's channels, with
// the noise model of method_measurement.hpp: measurement_noise.cpp).
References references_of(const Captures& captures);

// The recipe's channels (the default's spelled out: R, G, B of every capture).
std::vector<ChannelRecipe> recipe_channels(const Captures& captures);

}  // namespace chromo::session::measurement
