#pragma once
// The white and dark references of a measurement's captures and what is
// made from them, shared by the measurement builders (method_measurement.cpp)
// and the polarised surface correction (measurement_surface.cpp): per
// illumination the dark-subtracted white signal, its mean, noise and
// footprint; a capture's albedo ρ/g·(subject − dark)/(white − dark); the
// noise model of every channel (method_measurement.hpp). Internal to
// session/ (namespace measurement); pure functions, std::invalid_argument
// naming the capture for captures that cannot be used.

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
// inside the reference's footprint (g: the subject's exposure over its white's).
Normalised normalise(const IlluminatedCapture& capture, const Reference& reference, const RgbImage& dark, double rho);

// A plane as registration sees it: the pixels clipped in either capture,
// and their neighbours within 2 px, left out (NaN).
std::vector<float> unclipped_for_registration(const std::vector<float>& plane, const Normalised& a, const Normalised& b,
                                              int width, int height);

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
// blue-only channel, and D65' parallel when captured).
References references_of(const MethodCaptures& captures);

struct PlanReferences {
  std::vector<Reference> references;
  std::vector<ExposureLinearity> linearity;  // per capture
  estimation::MeasurementSet set;
};

// Any plan's references and measurement set: three channels per capture.
PlanReferences plan_references_of(const PlanCaptures& captures);

// Pixels outside the footprint of any white reference the measurement uses
// (MethodMeasurement::no_reference).
void mark_no_reference(MethodMeasurement& m, const std::vector<const Reference*>& references);

}  // namespace chromo::session::measurement
