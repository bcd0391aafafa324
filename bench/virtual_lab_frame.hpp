#pragma once
// Measurement frames rendered from the virtual lab's skin scene
// (simulators/scene: SkinModel albedo with smooth Cm, Ch, βm, Che fields,
// moles, a vein, tattoo, marker, hair, a specular highlight), for the
// estimation bench: every channel of the measurement set is Σ weights·albedo
// per scene pixel, then the camera noise model of estimation/synthetic.hpp
// (shot + read noise, 12-bit counts, clipping; the synthesised blue-only
// channel with the read noise of both captures).
//
// Known truth at the scene's own resolution. A larger frame (the 5
// megapixels) is the rendered measurement resampled bilinearly before the
// noise — a smooth skin field, spatially coherent as a camera frame is; its
// parameters are the bilinearly resampled truth maps (approximate between
// scene pixels, so accuracy is measured at the scene's resolution).

#include <cstdint>
#include <vector>

#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/estimation/synthetic.hpp"

struct LabFrame {
  int width = 0, height = 0;
  std::vector<float> clean, noisy;                    // pixels × channels
  std::vector<chromo::estimation::SkinParameters> truth;
  std::vector<std::uint8_t> region;                   // simulators::SceneRegion per pixel
  std::size_t pixels() const { return truth.size(); }
};

// set's channel noise is replaced by noise's (as make_synthetic_frame does).
// scene_width × scene_height scene, resampled to width × height.
LabFrame render_lab_frame(chromo::estimation::MeasurementSet& set, const chromo::estimation::CameraNoiseModel& noise,
                          int scene_width, int scene_height, int width, int height, std::uint64_t seed);
