#pragma once
// Relighting parameter maps: the model's albedo of every pixel seen under any
// illuminant (the paper's reconstructions under the sphere's LEDs, D65, A...).
//
// Illuminants are named as a lab member types them (resolve_illuminant):
//   W57, W40, W27, R, G, B   the sphere's six LED types (measured spectra)
//   D65, D50, A              CIE standard illuminants (case-insensitive)
//   4000K, 6500k, ...        a correlated colour temperature, 1000-25000 K:
//                            Planck's law below 5000 K, CIE daylight from
//                            5000 K up (CIE 15:2004's recommendation)
//   anything else            a CSV file `wavelength_nm, value` (spectral::read_spectrum_file)
//
// Colour: linear sRGB per MODEL.md (XYZ with the illuminant's white at Y = 1,
// Bradford to D65, IEC 61966-2-1 matrix), so a white of albedo 1 maps to
// (1, 1, 1) under any illuminant; the PNG previews are its encoded, clipped form.
//
// Which pixels are relit: those whose four parameters are finite and whose
// flag is not 1-3 (non-finite input, saturated, dark: the estimator stored
// zeros there). Specular (4) and unexplained (5, 6) pixels carry the
// estimator's best fit and are relit with it. Relit pixels are marked in
// RelitImage::valid; the others are (0, 0, 0).
//
// All functions are thread-safe.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "chromo/maps/profile_table.hpp"  // ParameterMaps
#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::maps {

struct NamedSpectrum {
  std::string name;  // canonical: "W57", "D65", "4000K", or the file's stem ("d65prime")
  spectral::Spectrum spectrum;
};

// Throws std::invalid_argument naming the text and what was wrong (unknown
// name, CCT out of range, unreadable or malformed file).
NamedSpectrum resolve_illuminant(const std::string& name_cct_or_file);

// Planck's law at the temperature, normalised to 100 at 560 nm.
spectral::Spectrum planckian_illuminant(double cct_K);

// 3 × 81 (the camera weights' type): linear sRGB (white = 1) = matrix · albedo spectrum, under the illuminant.
spectral::CameraWeights linear_srgb_weights(const spectral::Spectrum& illuminant);

// Which pixels relight() relights (see above).
bool is_relightable(const ParameterMaps& maps, std::size_t pixel);
estimation::SkinParameters parameters_at(const ParameterMaps& maps, std::size_t pixel);

struct RelitImage {
  int width = 0, height = 0;
  std::vector<float> rgb;            // pixel-major R, G, B (linear)
  std::vector<std::uint8_t> valid;   // 1 = relit
};

// The forward model's albedo of every relightable pixel, plus its posterior
// discrepancy where maps.discrepancy holds one (the relit layer "model +
// discrepancy", discrepancy_layer.hpp; reset it to relight the model alone),
// projected with `weights` (3 × 81: linear_srgb_weights(), or a camera's
// camera_weights()). Exact model (no table), in blocks, on `threads` threads
// (0 = all cores).
RelitImage relight(const ParameterMaps& maps, const spectral::CameraWeights& weights,
                   int threads = 0);

}  // namespace chromo::maps
