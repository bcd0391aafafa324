#pragma once
// Colour differences (MODEL.md, "Colour").
//
// delta_e94 uses the graphic-arts constants (kL = kC = kH = 1, K1 = 0.045,
// K2 = 0.015) and is ASYMMETRIC: the first argument is the reference (truth,
// photograph, measured spectrum) and supplies C* for the weights
// SC = 1 + K1·C*ref and SH = 1 + K2·C*ref.
// delta_e00 is CIEDE2000 as Sharma, Wu & Dalal 2005 implement it (symmetric).

#include "chromo/spectral/colorimetry.hpp"

namespace chromo::spectral {

double delta_e76(const Lab& reference, const Lab& sample);
double delta_e94(const Lab& reference, const Lab& sample);
double delta_e00(const Lab& lab1, const Lab& lab2);

}  // namespace chromo::spectral
