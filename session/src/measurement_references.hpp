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
// (MethodMeasurement::no_reference).
void mark_no_reference(MethodMeasurement& m, const std::vector<const Reference*>& references);

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

// The method's references and measurement set (D65', W57, W57+blue, the
// blue-only channel, and D65' parallel when captured), with the noise model
// of method_measurement.hpp (measurement_noise.cpp).
References references_of(const MethodCaptures& captures);

struct PlanReferences {
  std::vector<Reference> references;
  std::vector<ExposureLinearity> linearity;  // per capture
  estimation::MeasurementSet set;
};

// Any plan's references and measurement set: three channels per capture.
PlanReferences plan_references_of(const PlanCaptures& captures);

}  // namespace chromo::session::measurement
