#pragma once
// sRGB for previews (MODEL.md): XYZ scaled so the white has Y = 1,
// Bradford-adapted from the illuminant's white to D65, then the IEC 61966-2-1
// matrix and transfer function.

#include "chromo/spectral/colorimetry.hpp"

namespace chromo::spectral {

struct Rgb {
  double r = 0, g = 0, b = 0;
};

// Bradford chromatic adaptation of xyz from source_white to destination_white
// (both whites in the same scale as each other; xyz in any scale).
Xyz bradford_adapt(const Xyz& xyz, const Xyz& source_white, const Xyz& destination_white);

// Linear sRGB of an XYZ given at Y = 100 for the illuminant's white.
Rgb linear_srgb_from_xyz(const Xyz& xyz_y100, const Xyz& illuminant_white_y100);
// IEC 61966-2-1 encoding of one linear value (not clipped).
double srgb_encode(double linear);
// Encoded sRGB, each channel clipped to [0, 1].
Rgb srgb_from_xyz(const Xyz& xyz_y100, const Xyz& illuminant_white_y100);

}  // namespace chromo::spectral
