#pragma once
// What a polarised capture keeps of the surface (polarisation-keeping)
// reflection, as the estimator knows it (docs/polarisation.md, "What the
// estimator knows of the films").
//
// In albedo units (a capture divided by the white reference of its own
// state, which removes the films' diffuse transmission T_P·T_A) a capture of
// skin is d + c(λ)·s: d the depolarised subsurface albedo, s the surface
// reflection (flat in wavelength: Fresnel at η = 1.4), c the state's surface
// factor. For identical films of extinction ratio ER(λ) = k1/k2 crossed
// exactly (the design view):
//   c_cross(λ)    = 4·ER/(1 + ER)²            (0.0198 at 1:200, 0.181 at 1:20)
//   c_parallel(λ) = 2·(1 + ER²)/(1 + ER)²
// A camera channel c under illuminant E (the light as the camera sees it
// through the films) averages a factor with the weights S_c(λ)·E(λ), exactly
// for a flat s: channel_surface_factor.
//
// Where the factors come from in a lab: the films' datasheet curves k1(λ),
// k2(λ) (surface_factors_of_extinction), or better one measurement per camera
// at installation of a polarisation-keeping, non-scattering target (black
// glass): its cross and parallel albedo are c_cross·s_glass and
// c_parallel·s_glass per channel, which also captures a view's geometric leak
// (docs/polarisation.md, "Geometry"). The white references cannot tell: the
// white target is depolarising, so its cross and parallel captures are equal
// whatever the films. Thread rules: pure functions.

#include <filesystem>
#include <string>

#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::session {

struct SurfaceFactors {
  spectral::Spectrum cross;     // c_cross(λ), albedo units
  spectral::Spectrum parallel;  // c_parallel(λ), albedo units
  std::string source;           // where the knowledge comes from (the report says it)
};

// Identical films crossed exactly, from their extinction ratio k1/k2 on the
// project grid. std::invalid_argument when a ratio is not finite or below 1.
SurfaceFactors surface_factors_of_extinction(const spectral::Spectrum& extinction_ratio, std::string source);

// The same from a datasheet curve: a CSV of wavelength_nm,extinction_ratio
// (k1/k2, ≥ 1; '#' provenance lines allowed), resampled onto the project
// grid as every spectrum is. std::invalid_argument naming the file when it
// is unreadable, has no extinction_ratio column or a ratio below 1.
SurfaceFactors surface_factors_of_extinction_file(const std::filesystem::path& path);

// Σ S_c·E·factor / Σ S_c·E over the grid. std::invalid_argument when the
// channel is outside 0-2 or the camera sees nothing of the illuminant in it.
double channel_surface_factor(const spectral::Spectrum& factor, const spectral::CameraSensitivity& camera,
                              const spectral::Spectrum& illuminant, int channel);

}  // namespace chromo::session
