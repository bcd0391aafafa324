#pragma once
// Radial diffuse reflectance profiles R(r) of the two-layer skin model, for
// renderers' subsurface-scattering integrators (issue "What the maps are
// for", item 4; format in docs/formats/profiles.md).
//
// The layers combine as Donner & Jensen 2005 do, in the frequency (Hankel)
// domain, with MODEL.md's single R1, T1 convention:
//     R(k) = R1(k) + T1(k)·R2(k)·T1(k) / (1 - R1(k)·R2(k)).
// Each layer's transform is the closed form MODEL.md uses for the albedo with
// σtr replaced by σk = sqrt(σtr² + k²): the 2D Fourier transform of one
// pole's exitance α'·z·(1 + σtr·ρ)·e^(-σtr·ρ) / (4π·ρ³), ρ = sqrt(r² + z²), is
// (α'/2)·sgn(z)·e^(-|z|·σk); at k = 0 it is the plane integral MODEL.md gives.
// So R(k = 0) is exactly the albedo of estimation::SkinModel.
//
// R1(r) is summed in space, pole by pole (its transform decays too slowly for
// a numerical inversion); the coupled remainder is inverted numerically,
//     R_rest(r) = (1/2π) ∫ G(k)·J0(k·r)·k dk   (trapezoid on a uniform k grid),
// and the spectra are projected onto linear sRGB under the chosen illuminant
// (Bradford to D65, IEC 61966-2-1 primaries; an albedo of 1 gives ≈ (1,1,1)).
// Light that has travelled millimetres through skin is deep red, outside the
// sRGB gamut, so far tails may dip slightly below zero in G and B (by < 1e-3
// of the channel's peak); a renderer clamps them.
//
// Thread rules: a RadialProfileModel is immutable after construction and
// profile() may be called from any number of threads at once.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "chromo/estimation/skin_model.hpp"

namespace chromo::maps {

struct RadialProfileOptions {
  // Log-spaced radii at which profiles are sampled.
  double min_radius_mm = 1e-4;
  double max_radius_mm = 16.0;  // skin's red tail has fallen by e^-8 there
  int radius_count = 160;
  // Uniform frequency grid of the numerical inversion. The step must be fine
  // against the largest radius (measured: the plane integral errs by about
  // 2%·(step·max_radius)², so IsValid requires step·max_radius ≤ 0.2); the top
  // must pass the coupled term's decay, which is at least e^(-k·2·l_dermis).
  double frequency_step_per_mm = 0.01;
  double max_frequency_per_mm = 150.0;

  bool IsValid(std::string* error) const;
};

struct RadialProfile {
  std::vector<double> radius_mm;
  // Linear sRGB reflectance per unit area (mm^-2), one row per radius.
  Eigen::Matrix<double, Eigen::Dynamic, 3> rgb_per_mm2;
  // The forward model's albedo in the same linear sRGB ...
  Eigen::Vector3d albedo_rgb;
  // ... and the profile integrated numerically over the plane (2πr dr on the
  // log-spaced radii, trapezoid in ln r). They agree within 0.5%.
  Eigen::Vector3d plane_integral_rgb;
};

class RadialProfileModel {
 public:
  // Throws std::invalid_argument when options.IsValid() fails.
  RadialProfileModel(const estimation::SkinModel& model, const spectral::Spectrum& illuminant, RadialProfileOptions options = {});

  RadialProfile profile(const estimation::SkinParameters& parameters) const;

  const std::vector<double>& radii_mm() const { return radii_mm_; }
  // Row c maps an albedo spectrum to linear sRGB channel c under the illuminant.
  const Eigen::Matrix<double, 3, spectral::kGridSize>& rgb_weights() const { return rgb_weights_; }

 private:
  const estimation::SkinModel& model_;
  RadialProfileOptions options_;
  std::vector<double> radii_mm_;
  std::vector<double> frequencies_per_mm_;
  Eigen::ArrayXd k_squared_;
  Eigen::MatrixXd hankel_kernel_;  // [radius][frequency]: J0(k r)·k·Δk/(2π), trapezoid weights included
  Eigen::Matrix<double, 3, spectral::kGridSize> rgb_weights_;
  double skin_air_a_;
};

}  // namespace chromo::maps
