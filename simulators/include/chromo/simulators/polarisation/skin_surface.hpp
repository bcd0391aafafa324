#pragma once
// Skin's surface layer in the virtual lab (docs/polarisation.md, "Virtual lab
// physics"): the Fresnel sheen everywhere and highlights on oily regions.
//
// Sheen: the exact (unpolarised, mean of s and p) Fresnel reflectance of the
// skin-air boundary at η = 1.4 for the camera's angle from the surface normal
// (a smooth boundary under the sphere's even irradiance reflects into the
// camera what the light from the mirror direction brings: F(θ)). At normal
// incidence F = ((η − 1)/(η + 1))² = 0.02778.

namespace chromo::simulators {

inline constexpr double kSkinRefractiveIndex = 1.4;

// Exact Fresnel reflectance of unpolarised light from air onto a dielectric of
// index eta, at incidence angle theta_rad (|θ| < π/2). Throws
// std::invalid_argument for eta ≤ 0 or |θ| ≥ π/2.
double fresnel_reflectance_unpolarised(double eta, double theta_rad);

}  // namespace chromo::simulators
