#pragma once
// What the mix solver aims at: a named target spectrum on the grid. Only its
// shape matters (the solver picks the brightness, mix_solver.hpp).

#include <string>
#include <string_view>

#include "chromo/calibration/led_library.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::calibration {

struct MixTarget {
  std::string name;            // "d65", "w57+blue:1", "cct:5000", or the file path
  spectral::Spectrum spectrum;
};

MixTarget d65_target();
// CIE daylight at cct_K (4000-25000 K; the CIE formula's nominal CCT, so
// cct:6500 is D65 to within the 5 nm table rounding). DataError outside.
MixTarget daylight_target(double cct_K);
// The second illumination state of the method: W57 plus blue, with the blue
// LED's contribution to the camera's B channel equal to blue_to_w57_ratio
// times W57's (default 1). Built from this library's spectra, so the solver
// reproduces it exactly when the drive limits allow.
MixTarget w57_plus_blue_target(const LedLibrary& library, const spectral::CameraSensitivity& camera,
                               double blue_to_w57_ratio = 1.0);
// Any SPD from a CSV (wavelength_nm, value), resampled by MODEL.md's rule.
MixTarget file_target(const std::string& path);

// "d65", "w57+blue", "w57+blue:R", "cct:K", or a path ending in .csv
// (case-insensitive keywords). DataError naming the spec when it is none of
// these, R is not a positive number, K is out of range, or the file is bad.
MixTarget parse_mix_target(std::string_view spec, const LedLibrary& library, const spectral::CameraSensitivity& camera);

}  // namespace chromo::calibration
