#include "chromo/estimation/measurement.hpp"

#include <cmath>
#include <stdexcept>

namespace chromo::estimation {

Eigen::MatrixXd MeasurementSet::weights() const {
  Eigen::MatrixXd w(size(), spectral::kGridSize);
  for (int c = 0; c < size(); ++c) {
    const spectral::CameraWeights all = spectral::camera_weights(camera, channels[c].illuminant);
    w.row(c) = all.row(channels[c].camera_channel);
  }
  return w;
}

void MeasurementSet::validate() const {
  if (channels.empty()) throw std::invalid_argument("measurement set has no channels");
  for (const MeasurementChannel& c : channels) {
    if (c.camera_channel < 0 || c.camera_channel > 2)
      throw std::invalid_argument("channel '" + c.name + "': camera channel " + std::to_string(c.camera_channel) +
                                  " is not 0 (R), 1 (G) or 2 (B)");
    const double power = (camera.rgb[c.camera_channel] * c.illuminant).values().sum();
    if (!(power > 0) || !c.illuminant.values().allFinite())
      throw std::invalid_argument("channel '" + c.name + "': the illuminant gives no signal in this camera channel");
    if (!(c.noise.read_sigma > 0) || !(c.noise.shot_coefficient >= 0) || !(c.noise.white_coefficient >= 0) ||
        !(c.noise.saturation_albedo > 0))
      throw std::invalid_argument("channel '" + c.name + "': noise needs read_sigma > 0, shot_coefficient >= 0, "
                                  "white_coefficient >= 0, saturation_albedo > 0");
  }
}

MeasurementSet method_measurement_set(const spectral::CameraSensitivity& camera, const spectral::Spectrum& d65_prime,
                                      const spectral::Spectrum& mix_minus_w57, const ChannelNoise& noise) {
  MeasurementSet set = rgb_measurement_set(camera, d65_prime, noise, "D65'");
  ChannelNoise blue_noise = noise;
  // Difference of two captures: the read noise of both adds.
  blue_noise.read_sigma = noise.read_sigma * std::sqrt(2.0);
  set.channels.push_back({"blue.B", mix_minus_w57, 2, blue_noise});
  return set;
}

MeasurementSet rgb_measurement_set(const spectral::CameraSensitivity& camera, const spectral::Spectrum& illuminant,
                                   const ChannelNoise& noise, const std::string& name) {
  MeasurementSet set{camera, {}};
  const char* names[3] = {".R", ".G", ".B"};
  for (int c = 0; c < 3; ++c) set.channels.push_back({name + names[c], illuminant, c, noise});
  return set;
}

}  // namespace chromo::estimation
