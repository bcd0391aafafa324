#pragma once
// The virtual lab's skin scene (simulators/scene) photographed through the
// camera model (simulators/camera/camera_model.hpp, noise on) as the method's
// measurement set, for the estimation tests that need spatial structure and
// region labels as truth.
//
// Captures (three-channel sensor at scene resolution, 0 dB):
//   D65'       R, G, B under the six-LED D65 metamer;
//   W57, mix   W57 alone and W57 + blue; the blue-only channel is
//              (mix − W57).B normalised by the same difference of a white.
// Exposure: a white of albedo 1 fills exposure_fill of the full well in its
// brightest channel (0.8: the white target and every skin pixel stay below
// clipping; 2.0 makes the specular highlight and the white target clip).
// Values are albedo = electrons / electrons of a white, with the white's
// electrons known exactly (a real session averages white frames). A pixel
// whose raw value clipped in a capture gets its channel set to that channel's
// saturation albedo (the estimator's "at or above" rule). Each channel's noise
// (measurement.hpp) is derived from the camera's electrons, read noise and
// quantisation; the blue-only channel carries both captures' noise.

#include <opencv2/core.hpp>

#include <vector>

#include "chromo/estimation/measurement.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::estimation::testing {

struct LabScene {
  simulators::Scene scene;
  MeasurementSet set;
  int width = 0, height = 0;
  std::vector<float> measured;     // width·height·4, pixel-major, the method's channels
  std::vector<bool> clipped;       // per pixel: a capture clipped (truth for "saturated")
  // Per pixel, the flat surface reflection make_skin_scene added (its
  // highlight's ellipse, 0.3·spec; labelled kSpecular where ≥ 0.006), for
  // reporting the flagged share by strength.
  std::vector<float> added_reflection;
  // Per pixel, the share the marker's dye covers (labelled kMarker where > 0).
  std::vector<float> marker_cover;
  simulators::SceneRegion region(std::size_t pixel) const {
    return static_cast<simulators::SceneRegion>(scene.regions().at<std::uint8_t>(static_cast<int>(pixel) / width,
                                                                                  static_cast<int>(pixel) % width));
  }
};

LabScene render_lab_scene(int size, double exposure_fill = 0.8, std::uint64_t seed = 1);

}  // namespace chromo::estimation::testing
