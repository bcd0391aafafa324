// The measurement builders: a session's captures → the albedo measurement
// an inverter is given (method_measurement.hpp). The white references and
// albedo are measurement_albedo.cpp's, the noise model measurement_noise.cpp's,
// the polarised surface correction measurement_surface.cpp's; here, what the
// method and any plan share (registration onto the first capture,
// photographs, exposures, saturation) and the two builders.
#include "chromo/session/method_measurement.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "measurement_references.hpp"
#include "measurement_surface.hpp"

namespace chromo::session {

namespace {

using namespace measurement;

struct MovingCapture {
  Normalised* albedo;  // warped in place when it moved
  int channel;         // registered on this camera channel
  std::string name;    // the capture's ("W57")
};

// Registers every moving capture onto `fixed` (on its channel, the pixels
// clipped in either left out), all at once (register_channels honours
// options.threads), and warps the albedo planes and saturation mask of those
// whose motion is significant onto the fixed grid; one report per capture.
std::vector<RegistrationReport> register_onto(const Normalised& fixed, const std::string& fixed_name,
                                              const std::vector<MovingCapture>& moving, int width, int height,
                                              const RegistrationOptions& options) {
  const std::size_t n = static_cast<std::size_t>(width) * height;
  std::vector<RegistrationPair> pairs;
  for (const MovingCapture& k : moving)
    pairs.push_back({unclipped_for_registration(fixed.albedo[k.channel], fixed, *k.albedo, width, height),
                     unclipped_for_registration(k.albedo->albedo[k.channel], fixed, *k.albedo, width, height)});
  const std::vector<RegistrationResult> found = register_channels(pairs, width, height, options);
  pairs.clear();
  std::vector<RegistrationReport> reports;
  for (std::size_t j = 0; j < moving.size(); ++j) {
    Normalised& albedo = *moving[j].albedo;
    const RegistrationResult& r = found[j];
    const double motion = corner_displacement_px(r, width, height);
    const bool warped = motion_is_significant(r, motion);
    if (warped) {
      for (auto& plane : albedo.albedo) plane = warp_channel(plane, width, height, r);
      std::vector<float> s(albedo.saturated.begin(), albedo.saturated.end());
      s = warp_channel(s, width, height, r);
      for (std::size_t i = 0; i < n; ++i) albedo.saturated[i] = std::isfinite(s[i]) && s[i] > 0;
    }
    reports.push_back({"subject under " + moving[j].name, "subject under " + fixed_name, kChannelNames[moving[j].channel],
                       r, motion, warped});
  }
  return reports;
}

// A capture's photograph (what the relit comparison is against): its albedo as captured.
Photograph photograph_of(const IlluminatedCapture& capture, const Normalised& albedo,
                         const std::array<estimation::ChannelNoise, 3>& noise) {
  const std::size_t n = albedo.albedo[0].size();
  Photograph photo{capture.name, capture.illuminant, std::vector<Eigen::Vector3d>(n), noise};
  for (std::size_t i = 0; i < n; ++i) photo.rgb[i] = {albedo.albedo[0][i], albedo.albedo[1][i], albedo.albedo[2][i]};
  return photo;
}

// A capture's white and subject exposures in MethodMeasurement::exposures.
void add_exposures(MethodMeasurement& m, const IlluminatedCapture& capture) {
  m.exposures.push_back({"white " + capture.name, capture.white.exposure_us, capture.white.frames});
  m.exposures.push_back({"subject " + capture.name, capture.subject.exposure_us, capture.subject.frames});
}

// A pixel with a raw subject value at full scale: counted, and each finite
// channel of `measured` (m.set.size() values) raised to at least its
// saturation albedo (the estimator then flags it kSaturated).
void mark_saturated(MethodMeasurement& m, float* measured) {
  ++m.saturated_pixels;
  for (int c = 0; c < m.set.size(); ++c)
    if (std::isfinite(measured[c]))
      measured[c] = std::max(measured[c], static_cast<float>(m.set.channels[c].noise.saturation_albedo));
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
  // Each capture on its white's brightest channel against the first, the captures at once.
  std::vector<MovingCapture> moving;
  for (std::size_t k = 1; k < normalised.size(); ++k) {
    const Reference& reference = references.references[k];
    const int channel = static_cast<int>(std::max_element(reference.white_mean.begin(), reference.white_mean.end()) -
                                         reference.white_mean.begin());
    moving.push_back({&normalised[k], channel, captures.captures[k].name});
  }
  m.registration = register_onto(normalised.front(), captures.captures.front().name, moving, width, height, options);
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
    if (saturated) mark_saturated(m, out);
  }
  for (std::size_t k = 0; k < normalised.size(); ++k) {
    std::array<estimation::ChannelNoise, 3> noise;
    for (int c = 0; c < 3; ++c) noise[c] = m.set.channels[3 * k + c].noise;
    m.photographs.push_back(photograph_of(captures.captures[k], normalised[k], noise));
  }
  m.exposures.push_back({"dark", dark.exposure_us, dark.frames});
  for (const IlluminatedCapture& capture : captures.captures) add_exposures(m, capture);
  return m;
}

estimation::MeasurementSet method_set_from_references(const MethodCaptures& captures) { return references_of(captures).set; }

std::vector<spectral::Spectrum> photograph_illuminants(const MethodCaptures& captures) {
  return {captures.broadband.illuminant, captures.base.illuminant, captures.with_blue.illuminant};
}

std::vector<spectral::Spectrum> photograph_illuminants(const PlanCaptures& captures) {
  std::vector<spectral::Spectrum> out;
  for (const IlluminatedCapture& capture : captures.captures) out.push_back(capture.illuminant);
  return out;
}

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
  m.registration = register_onto(broadband, captures.broadband.name,
                                 {{&base, 1, captures.base.name}, {&with_blue, 1, captures.with_blue.name}}, width,
                                 height, options);

  mark_no_reference(m, {&references.broadband, &references.base, &references.with_blue});
  // The photographs (what the relit comparison is against) as captured.
  const std::pair<const Normalised*, const IlluminatedCapture*> photographed[] = {
      {&broadband, &captures.broadband}, {&base, &captures.base}, {&with_blue, &captures.with_blue}};
  for (std::size_t p = 0; p < std::size(photographed); ++p) {
    const auto& [k, capture] = photographed[p];
    m.photographs.push_back(photograph_of(*capture, *k, references.capture_noise[p]));
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
    if (broadband.saturated[i] || base.saturated[i] || with_blue.saturated[i]) mark_saturated(m, out);
  }

  m.exposures.push_back({"dark", dark.exposure_us, dark.frames});
  for (const IlluminatedCapture* capture : {&captures.broadband, &captures.base, &captures.with_blue})
    add_exposures(m, *capture);
  if (const auto& parallel = captures.broadband_parallel) add_exposures(m, *parallel);
  return m;
}

}  // namespace chromo::session
