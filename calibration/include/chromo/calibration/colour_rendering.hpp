#pragma once
// CIE colour rendering index, CIE 13.3-1995: Ra (mean of R1-R8) and the
// special indices R9-R14, from the test colour samples in data/cie_tcs.csv.
//
// Method, step by step as CIE 13.3 prescribes:
//  1. CCT of the test light (planck.hpp: nearest point of the Planckian locus
//     in CIE 1960 UCS).
//  2. Reference illuminant: a Planckian radiator at that CCT below 5000 K,
//     else CIE daylight (CIE D series) at that CCT. The D-series formula was
//     defined on the old scale c2 = 1.4380e-2 m·K; a modern CCT T is T·1.4380
//     /1.4388 on that scale (so D65 is "6500 K" there and 6504 K here).
//  3. Each TCS under both lights, Y of each light scaled to 100; von Kries
//     adaptation of the test samples in CIE 1960 (c, d) coordinates to the
//     reference white; CIE 1964 U*V*W*; Ri = 100 - 4.6·ΔE_i.
// Everything runs on the project grid (380-780 nm, 5 nm), so results can
// differ from 1 nm implementations by a few hundredths.

#include <array>

#include "chromo/spectral/spectrum.hpp"

namespace chromo::calibration {

struct ColourRendering {
  double ra = 0;                    // general index, mean of R1..R8
  std::array<double, 14> r{};       // special indices R1..R14 (r[0] is R1)
  double cct_K = 0;                 // of the test light
  double duv = 0;                   // signed distance from the Planckian locus (CIE 1960)
  // CIE 13.3 only defines the index for lights close to the Planckian locus
  // (|DC| < 5.4e-3); outside it the numbers are computed anyway but flagged.
  bool near_planckian_locus = false;
};

// The light must have positive luminance (std::invalid_argument otherwise).
ColourRendering colour_rendering_index(const spectral::Spectrum& light);

}  // namespace chromo::calibration
