#include "chromo/spectral/colorimetry.hpp"

#include <gtest/gtest.h>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/srgb.hpp"
#include "chromo/spectral/table.hpp"

using namespace chromo::spectral;

namespace {

TEST(Colorimetry, AlbedoOneReproducesTheD65WhitePoint) {
  const Xyz w = xyz_of_reflectance(Spectrum::constant(1.0), illuminant_d65());
  // CIE D65, 2° observer: (95.047, 100, 108.883). Our 5 nm bin means of the
  // 1 nm tables land within 0.05 of it.
  EXPECT_NEAR(w.X, 95.047, 0.05);
  EXPECT_DOUBLE_EQ(w.Y, 100.0);
  EXPECT_NEAR(w.Z, 108.883, 0.05);
  const Chromaticity xy = chromaticity(w);
  EXPECT_NEAR(xy.x, 0.31272, 2e-4);
  EXPECT_NEAR(xy.y, 0.32903, 2e-4);
  const Lab lab = lab_from_xyz(w, white_point(illuminant_d65()));
  EXPECT_NEAR(lab.L, 100.0, 1e-12);
  EXPECT_NEAR(lab.a, 0.0, 1e-12);
  EXPECT_NEAR(lab.b, 0.0, 1e-12);
}

TEST(Colorimetry, IlluminantAAndD50WhitePoints) {
  const Xyz a = white_point(illuminant_a());
  EXPECT_NEAR(a.X, 109.850, 0.05);
  EXPECT_NEAR(a.Z, 35.585, 0.05);
  const Xyz d50 = white_point(illuminant_d50());
  EXPECT_NEAR(d50.X, 96.422, 0.05);
  EXPECT_NEAR(d50.Z, 82.521, 0.05);
}

TEST(Colorimetry, LabHandWorked) {
  // XYZ (20, 18, 10) with white (95.047, 100, 108.883):
  // fy = cbrt(0.18) = 0.564622, fx = cbrt(0.210422) = 0.594790,
  // fz = cbrt(0.091842) = 0.451177 → L = 49.4961, a = 15.0843, b = 22.6890.
  const Lab lab = lab_from_xyz({20, 18, 10}, {95.047, 100, 108.883});
  EXPECT_NEAR(lab.L, 49.4962, 1e-3);
  EXPECT_NEAR(lab.a, 15.0843, 1e-3);
  EXPECT_NEAR(lab.b, 22.6890, 1e-3);
  const Xyz back = xyz_from_lab(lab, {95.047, 100, 108.883});
  EXPECT_NEAR(back.X, 20, 1e-9);
  EXPECT_NEAR(back.Y, 18, 1e-9);
  EXPECT_NEAR(back.Z, 10, 1e-9);
  // Dark colours use the linear branch and still round-trip.
  const Xyz dark{0.5, 0.4, 0.3};
  const Xyz dark_back = xyz_from_lab(lab_from_xyz(dark, {95.047, 100, 108.883}), {95.047, 100, 108.883});
  EXPECT_NEAR(dark_back.Y, 0.4, 1e-12);
}

TEST(Colorimetry, SrgbOfTheIlluminantWhiteIsWhiteUnderAnyIlluminant) {
  for (const Spectrum* illuminant : {&illuminant_d65(), &illuminant_a(), &illuminant_d50()}) {
    const Xyz white = white_point(*illuminant);
    const Rgb rgb = linear_srgb_from_xyz(white, white);
    EXPECT_NEAR(rgb.r, 1.0, 2e-3);
    EXPECT_NEAR(rgb.g, 1.0, 2e-3);
    EXPECT_NEAR(rgb.b, 1.0, 2e-3);
    // An 18% grey stays neutral after Bradford adaptation.
    const Rgb grey = linear_srgb_from_xyz(xyz_of_reflectance(Spectrum::constant(0.18), *illuminant), white);
    EXPECT_NEAR(grey.r, 0.18, 1e-3);
    EXPECT_NEAR(grey.b, 0.18, 1e-3);
  }
  EXPECT_NEAR(srgb_encode(0.18), 0.46135, 1e-4);
  EXPECT_NEAR(srgb_encode(0.002), 0.02584, 1e-6);
}

TEST(Colorimetry, DaylightAt6504KIsCloseToD65) {
  const Spectrum d = daylight_illuminant(6504.0);
  const Chromaticity xy = chromaticity(white_point(d));
  EXPECT_NEAR(xy.x, 0.31272, 5e-4);
  EXPECT_NEAR(xy.y, 0.32903, 5e-4);
  EXPECT_THROW(daylight_illuminant(3000.0), DataError);
}

TEST(Colorimetry, IlluminantByNameOrFile) {
  EXPECT_EQ(illuminant_by_name_or_file("D65")[20], illuminant_d65()[20]);
  EXPECT_THROW(illuminant_by_name_or_file("d75"), DataError);
  EXPECT_THROW(illuminant_by_name_or_file("/nonexistent.csv"), DataError);
}

}  // namespace
