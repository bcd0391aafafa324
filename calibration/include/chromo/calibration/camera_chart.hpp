#pragma once
// What a camera sees of a colour chart under a light, the camera objective of
// the mix solver and its ΔE00 report (issue "Calibration", item 2):
//
//  - white-normalised linear camera RGB: patch p, channel c under light E is
//    Σ S_c·R_p·E / Σ S_c·E_target, i.e. normalised by what a white of albedo
//    1 gives under the TARGET, so a mix that is too bright or off-white
//    shows as an error (MODEL.md's camera response, with the target's white);
//  - ΔE00 report: each light's patch RGB white-normalised by ITS OWN white
//    (what the capture pipeline does: albedo = frame / white reference under
//    the same light, DESIGN.md), then a 3×3 matrix M mapping camera RGB to
//    XYZ, fitted by least squares on the chart under the target (XYZ with the
//    target's white at Y = 100); target and mix patch RGB both go through M,
//    to CIELAB with the target's white, and ΔE00 compares them. It measures
//    what the camera's albedo differs by, in roughly perceptual units, free of
//    the camera's own departure from the CIE observer and of the mix's
//    brightness and camera white balance (which the white reference removes).

#include <Eigen/Core>
#include <string>
#include <vector>

#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::calibration {

struct ColourChart {
  std::string name;
  std::vector<std::string> patch_names;
  std::vector<spectral::Spectrum> reflectance;
};
// ColorChecker Classic, Ohta 1997 (data/colorchecker_reflectance_ohta.csv).
const ColourChart& ohta_colour_checker();

// Rows (patch-major: p·3 + c) of the linear map light spectrum → white-
// normalised camera RGB of every patch, normalised by the target's white.
Eigen::MatrixXd camera_chart_rows(const spectral::CameraSensitivity& camera, const ColourChart& chart,
                                  const spectral::Spectrum& target);

struct ChartDeltaE {
  std::vector<double> delta_e00;  // per patch
  double mean = 0, max = 0;
};
ChartDeltaE camera_chart_delta_e00(const spectral::CameraSensitivity& camera, const ColourChart& chart,
                                   const spectral::Spectrum& target, const spectral::Spectrum& mix);

}  // namespace chromo::calibration
