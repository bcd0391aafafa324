#pragma once
// CIE colorimetry on the grid (MODEL.md, "Colour"): CIE 1931 2° observer;
// reflectances are seen under an illuminant whose own white has Y = 100;
// CIELAB uses that white as reference.

#include "chromo/spectral/spectrum.hpp"

namespace chromo::spectral {

struct Xyz {
  double X = 0, Y = 0, Z = 0;
};
struct Lab {
  double L = 0, a = 0, b = 0;
};
struct Chromaticity {
  double x = 0, y = 0;
};
struct UvPrime {
  double u = 0, v = 0;
};

// Unnormalised tristimulus of a light: Σ spd · cmf · Δλ.
Xyz xyz_of_light(const Spectrum& spd);
// The illuminant's white, scaled to Y = 100.
Xyz white_point(const Spectrum& illuminant);
// A reflectance (albedo) seen under the illuminant; a perfect white gives
// white_point(illuminant).
Xyz xyz_of_reflectance(const Spectrum& reflectance, const Spectrum& illuminant);

Lab lab_from_xyz(const Xyz& xyz, const Xyz& white);
Xyz xyz_from_lab(const Lab& lab, const Xyz& white);
Chromaticity chromaticity(const Xyz& xyz);
UvPrime uv_prime(const Xyz& xyz);

}  // namespace chromo::spectral
