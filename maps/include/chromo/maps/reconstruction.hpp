#pragma once
// Reconstruction: from parameter maps back to spectra and images.
//  - albedo spectra per pixel (the pinned forward model, exact, both cores);
//  - their CIELAB under any illuminant (MODEL.md colour conventions);
//  - their camera image under any illuminant;
//  - ΔE94 statistics of a reconstruction against a reference, where the
//    reference is either known spectra/parameters (synthetic truth) or a
//    photograph: camera RGB under the illuminant, converted to XYZ with a 3×3
//    matrix fitted (least squares, ColorChecker reflectances of Ohta) for that
//    camera and illuminant and applied to the photograph and to the
//    reconstruction's camera image alike, so the comparison is in CIELAB as the
//    paper's Table 2.
// Flagged pixels (flag != 0 and not specular) are skipped by the statistics.
// All functions are thread-safe.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/colorimetry.hpp"

namespace chromo::maps {

struct DeltaEStats {
  double mean = 0, median = 0, p95 = 0, max = 0;
  std::size_t pixels = 0;
};
// Statistics of a list of ΔE values (empty list: all zero).
DeltaEStats delta_e_stats(std::vector<double> values);

// CIELAB of the model's albedo for each parameter set under the illuminant.
std::vector<spectral::Lab> relit_lab(std::span<const estimation::SkinParameters> parameters, const spectral::Spectrum& illuminant,
                                     int threads = 0);
// ΔE94(reference = truth, sample = estimate) per pixel under the illuminant.
std::vector<double> relit_delta_e94(std::span<const estimation::SkinParameters> truth, std::span<const estimation::SkinParameters> estimate,
                                    const spectral::Spectrum& illuminant, int threads = 0);

// Camera RGB (linear albedo, white = 1) of the model's albedo under the illuminant.
std::vector<Eigen::Vector3d> relit_camera_rgb(std::span<const estimation::SkinParameters> parameters,
                                              const spectral::CameraSensitivity& camera,
                                              const spectral::Spectrum& illuminant, int threads = 0);

// Camera RGB (white = 1) → XYZ (white Y = 100) for this camera and illuminant.
Eigen::Matrix3d camera_to_xyz_matrix(const spectral::CameraSensitivity& camera, const spectral::Spectrum& illuminant);

// Per pixel ΔE94 of reconstruction against a photograph (both camera RGB,
// white = 1, under `illuminant`); NaN where either is not finite.
std::vector<double> photo_delta_e94_map(std::span<const Eigen::Vector3d> photograph,
                                        std::span<const Eigen::Vector3d> reconstruction,
                                        const spectral::CameraSensitivity& camera, const spectral::Spectrum& illuminant);

// The CIELAB of each camera RGB (white = 1) under `illuminant`
// (camera_to_xyz_matrix and the illuminant's white), every core for a large
// image; all three NaN where the RGB is not finite. What photo_delta_e94_map
// converts, made once where several comparisons share a photograph.
std::vector<spectral::Lab> photo_lab_map(std::span<const Eigen::Vector3d> rgb, const spectral::CameraSensitivity& camera,
                                         const spectral::Spectrum& illuminant);

// Per pixel ΔE94 of `sample` against `reference` (photo_lab_map's); NaN
// where either is NaN. Sizes differ: std::invalid_argument.
std::vector<double> delta_e94_map(std::span<const spectral::Lab> reference, std::span<const spectral::Lab> sample);

// What a photograph's own noise alone gives in a comparison against it: per
// pixel, ΔE94 of the photograph against itself with one draw of its noise
// model added (σ_c² = noise[c].variance(albedo_c); normal draws from `seed`,
// so the same photograph gives the same figures). A reconstruction free of
// error still differs from a photograph by this much; NaN where the pixel is
// not finite.
std::vector<double> photograph_noise_delta_e94_map(std::span<const Eigen::Vector3d> photograph,
                                                   const std::array<estimation::ChannelNoise, 3>& noise,
                                                   const spectral::CameraSensitivity& camera,
                                                   const spectral::Spectrum& illuminant, std::uint64_t seed = 1);

// The same with the photograph's Lab given (photo_lab_map of it, same
// size): the same figures bit for bit, without converting the photograph again.
std::vector<double> photograph_noise_delta_e94_map(std::span<const Eigen::Vector3d> photograph,
                                                   std::span<const spectral::Lab> photograph_lab,
                                                   const std::array<estimation::ChannelNoise, 3>& noise,
                                                   const spectral::CameraSensitivity& camera,
                                                   const spectral::Spectrum& illuminant, std::uint64_t seed = 1);

// Statistics of photo_delta_e94_map over the pixels where include[i] (or all
// if empty) and the value is finite.
DeltaEStats photo_delta_e94(std::span<const Eigen::Vector3d> photograph, std::span<const Eigen::Vector3d> reconstruction,
                            const spectral::CameraSensitivity& camera, const spectral::Spectrum& illuminant,
                            std::span<const bool> include = {});

}  // namespace chromo::maps
