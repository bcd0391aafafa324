#include "lab_scene.hpp"

#include <algorithm>
#include <cmath>

#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/simulators/camera/camera_model.hpp"

namespace chromo::estimation::testing {

LabScene render_lab_scene(int size, double exposure_fill, std::uint64_t seed) {
  simulators::SkinSceneOptions scene_options;
  scene_options.width = scene_options.height = size;
  scene_options.seed = seed;
  LabScene lab{simulators::make_skin_scene(scene_options), {}, size, size, {}, {}, {}, {}};
  simulators::CameraModelOptions camera_options;
  camera_options.seed = seed;
  const simulators::CameraModel camera(camera_options);
  const spectral::Spectrum d65 = spectral::led_d65_metamer(), w57 = spectral::led_spectrum(spectral::LedType::kW57),
                           blue = spectral::led_spectrum(spectral::LedType::kBlue), mix = w57 + blue;
  const double full_well = camera_options.full_well_e, read_e = camera_options.read_noise_e;
  const double e_per_dn = camera_options.gain_e_per_dn, black = camera_options.black_level_dn;
  const double quantisation_e2 = e_per_dn * e_per_dn / 12.0;

  // Electrons of a white of albedo 1 per channel and microsecond.
  auto white_rate = [&](const spectral::Spectrum& irradiance) {
    Eigen::Vector3d rate = camera.weights(irradiance).rowwise().sum() * camera_options.quantum_scale_e_per_us;
    return rate;
  };
  const Eigen::Vector3d rate_d65 = white_rate(d65), rate_w57 = white_rate(w57), rate_mix = white_rate(mix);
  const double exposure_d65_us = exposure_fill * full_well / rate_d65.maxCoeff();
  const double exposure_mix_us = exposure_fill * full_well / rate_mix.maxCoeff();
  // The camera's production readout (band streams, camera_model.hpp). The
  // flag tests' bounds come from the spread over scene seeds 1-6 with it
  // (docs/estimation.md, "Flags across scale, exposure and scenes").
  auto capture = [&](const spectral::Spectrum& irradiance, double exposure_us, std::uint64_t frame) {
    return camera.expose(lab.scene.render(camera.weights(irradiance)), simulators::SensorLayout::kThreeChannel, 0, 0,
                         exposure_us, 0.0, frame);
  };
  const cv::Mat raw_d65 = capture(d65, exposure_d65_us, 1), raw_w57 = capture(w57, exposure_mix_us, 2),
                raw_mix = capture(mix, exposure_mix_us, 3);

  // The measurement set with noise in albedo units: σ² = (a·E + read² + q²)/E², E = a white's electrons.
  lab.set = method_measurement_set(camera_options.sensitivity, d65, blue);
  for (int c = 0; c < 3; ++c) {
    const double white_e = rate_d65[c] * exposure_d65_us;
    lab.set.channels[c].noise = {std::sqrt(read_e * read_e + quantisation_e2) / white_e, 1.0 / white_e,
                                 full_well / white_e};
  }
  const double blue_white_e = (rate_mix[2] - rate_w57[2]) * exposure_mix_us;
  const double typical_w57_e = 0.3 * rate_w57[2] * exposure_mix_us;  // skin-level W57 shot noise, counted twice
  lab.set.channels[3].noise = {std::sqrt(2 * (read_e * read_e + quantisation_e2 + typical_w57_e)) / blue_white_e,
                               1.0 / blue_white_e, full_well / blue_white_e};

  const std::size_t pixels = static_cast<std::size_t>(size) * size;
  lab.measured.resize(pixels * 4);
  lab.clipped.assign(pixels, false);
  lab.added_reflection.resize(pixels);
  lab.marker_cover.resize(pixels);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * size + x;
      lab.added_reflection[p] = static_cast<float>(simulators::skin_scene_added_reflection(size, size, x, y));
      lab.marker_cover[p] = static_cast<float>(simulators::skin_scene_marker_cover(size, size, x, y));
    }
  const int top = camera.max_dn();
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * size + x;
      const auto& d = raw_d65.at<cv::Vec<std::uint16_t, 3>>(y, x);
      const auto& w = raw_w57.at<cv::Vec<std::uint16_t, 3>>(y, x);
      const auto& m = raw_mix.at<cv::Vec<std::uint16_t, 3>>(y, x);
      bool clipped = false;
      for (int c = 0; c < 3; ++c) {
        const bool clip = d[c] >= top;
        clipped |= clip || w[c] >= top || m[c] >= top;
        lab.measured[p * 4 + c] = clip ? static_cast<float>(lab.set.channels[c].noise.saturation_albedo)
                                       : static_cast<float>((d[c] - black) * e_per_dn / (rate_d65[c] * exposure_d65_us));
      }
      const bool blue_clip = m[2] >= top || w[2] >= top;
      lab.measured[p * 4 + 3] = blue_clip ? static_cast<float>(lab.set.channels[3].noise.saturation_albedo)
                                          : static_cast<float>((double(m[2]) - double(w[2])) * e_per_dn / blue_white_e);
      lab.clipped[p] = clipped;
    }
  return lab;
}

}  // namespace chromo::estimation::testing
