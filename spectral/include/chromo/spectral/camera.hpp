#pragma once
// Camera response (MODEL.md): the response of channel c to albedo a(λ) under
// illuminant E(λ) with sensitivity S_c(λ) is Σ S_c·E·a·Δλ, normalised so that
// an albedo of 1 gives 1 in every channel.

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <string>
#include <string_view>

#include "chromo/spectral/spectrum.hpp"

namespace chromo::spectral {

struct CameraSensitivity {
  std::string name;
  std::array<Spectrum, 3> rgb;  // R, G, B
};

// A camera compiled in from data/camera_sensitivity.csv: "nikon_d5100",
// "canon_eos_5d_mark_ii", "sony_ilce_7m3". DataError for other names.
CameraSensitivity builtin_camera(std::string_view name);
// A CSV with columns wavelength_nm, R, G, B.
CameraSensitivity read_camera_sensitivity(const std::filesystem::path& path);

// Per-channel weights w_c(λ) = S_c(λ)E(λ) / Σ S_c E: response = W · albedo.
// Compute once per (camera, illuminant) and reuse for many albedos.
using CameraWeights = Eigen::Matrix<double, 3, kGridSize, Eigen::RowMajor>;
CameraWeights camera_weights(const CameraSensitivity& camera, const Spectrum& illuminant);

Eigen::Vector3d camera_response(const CameraSensitivity& camera, const Spectrum& illuminant,
                                const Spectrum& albedo);

}  // namespace chromo::spectral
