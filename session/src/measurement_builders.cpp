// The measurement builders: a session's captures → the albedo measurement
// an inverter is given (method_measurement.hpp). The white references and
// albedo are measurement_albedo.cpp's, the noise model measurement_noise.cpp's,
// the polarised surface correction measurement_surface.cpp's; here the one
// builder: registration onto the first capture, photographs, the recipe's
// channels, saturation, exposures.
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

// A capture's white and subject exposures in Measurement::exposures.
void add_exposures(Measurement& m, const IlluminatedCapture& capture) {
  m.exposures.push_back({"white " + capture.name, capture.white.exposure_us, capture.white.frames});
  m.exposures.push_back({"subject " + capture.name, capture.subject.exposure_us, capture.subject.frames});
}

// A pixel with a raw subject value at full scale: counted, and each finite
// channel of `measured` (m.set.size() values) raised to at least its
// saturation albedo (the estimator then flags it kSaturated).
void mark_saturated(Measurement& m, float* measured) {
  ++m.saturated_pixels;
  for (int c = 0; c < m.set.size(); ++c)
    if (std::isfinite(measured[c]))
      measured[c] = std::max(measured[c], static_cast<float>(m.set.channels[c].noise.saturation_albedo));
}

// The recipe's channels at pixel i into `out` (one value per channel); a
// difference channel as the albedos weighted by their whites' signals.
void form_channels(const std::vector<ChannelRecipe>& channels, const References& references,
                   const std::vector<Normalised>& normalised, std::size_t i, float* out) {
  for (std::size_t j = 0; j < channels.size(); ++j) {
    const ChannelRecipe& recipe = channels[j];
    const int c = recipe.camera_channel;
    const float a = normalised[recipe.capture].albedo[c][i];
    if (!recipe.less) {
      out[j] = a;
      continue;
    }
    const double s = references.less_scale[j];
    const float wa = references.references[recipe.capture].white_signal[c][i];
    const float wb_raw = references.references[*recipe.less].white_signal[c][i];
    const float wb = s == 1 ? wb_raw : static_cast<float>(s * wb_raw);
    const float difference = wa - wb;
    out[j] = difference > 1e-3f ? (a * wa - normalised[*recipe.less].albedo[c][i] * wb) / difference : kNaN;
  }
}

// Each capture after the first on the recipe's registration channel (else
// its white's brightest) against the first, the captures at once.
std::vector<RegistrationReport> register_captures(const Captures& captures, const References& references,
                                                  std::vector<Normalised>& normalised, const RegistrationOptions& options) {
  std::vector<MovingCapture> moving;
  for (std::size_t k = 1; k < normalised.size(); ++k) {
    const Reference& reference = references.references[k];
    const int channel = captures.recipe.registration_channel.value_or(
        static_cast<int>(std::max_element(reference.white_mean.begin(), reference.white_mean.end()) -
                         reference.white_mean.begin()));
    moving.push_back({&normalised[k], channel, captures.captures[k].name});
  }
  return register_onto(normalised.front(), captures.captures.front().name, moving, captures.dark.width,
                       captures.dark.height, options);
}

}  // namespace

MeasurementRecipe standard_recipe() {
  MeasurementRecipe recipe;
  for (int c = 0; c < 3; ++c) recipe.channels.push_back({0, c, std::nullopt, {}});  // D65' R, G, B
  recipe.channels.push_back({2, 2, std::size_t{1}, "blue"});                        // W57+blue − W57, B
  recipe.registration_channel = 1;                                                  // G
  return recipe;
}

estimation::MeasurementSet measurement_set_from_references(const Captures& captures) {
  return references_of(captures).set;
}

std::vector<spectral::Spectrum> photograph_illuminants(const Captures& captures) {
  std::vector<spectral::Spectrum> out;
  for (const IlluminatedCapture& capture : captures.captures) out.push_back(capture.illuminant);
  return out;
}

Measurement build_measurement(const Captures& captures, const RegistrationOptions& options) {
  const References references = references_of(captures);
  const std::vector<ChannelRecipe> channels = recipe_channels(captures);
  const RgbImage& dark = captures.dark;
  const double rho = captures.white_reflectance;
  const std::size_t n = dark.pixels();
  std::vector<Normalised> normalised;
  for (std::size_t k = 0; k < captures.captures.size(); ++k)
    normalised.push_back(normalise(captures.captures[k], references.references[k], dark, rho));

  Measurement m;
  m.width = dark.width, m.height = dark.height;
  m.set = references.set;
  m.linearity = references.linearity;
  m.registration = register_captures(captures, references, normalised, options);
  std::vector<const Reference*> used;
  for (const Reference& reference : references.references) used.push_back(&reference);
  mark_no_reference(m, used);
  // The photographs (what the relit comparison is against) as captured.
  for (std::size_t k = 0; k < normalised.size(); ++k)
    m.photographs.push_back(photograph_of(captures.captures[k], normalised[k], references.capture_noise[k]));
  if (captures.parallel) {
    const auto parallel_saturated = add_surface_map(m, captures, references, normalised.front());
    if (captures.surface_factors) remove_surface_light(m, captures, parallel_saturated, normalised);
  }
  const int width = m.set.size();
  m.measured.resize(n * width);
  for (std::size_t i = 0; i < n; ++i) {
    float* out = &m.measured[i * width];
    form_channels(channels, references, normalised, i, out);
    if (std::any_of(normalised.begin(), normalised.end(), [i](const Normalised& k) { return k.saturated[i] != 0; }))
      mark_saturated(m, out);
  }
  m.exposures.push_back({"dark", dark.exposure_us, dark.frames});
  for (const IlluminatedCapture& capture : captures.captures) add_exposures(m, capture);
  if (const auto& parallel = captures.parallel) add_exposures(m, *parallel);
  return m;
}

}  // namespace chromo::session
