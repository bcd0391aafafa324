#include "chromo/spectral/colorimetry.hpp"

#include <cmath>

#include "chromo/spectral/cie.hpp"

namespace chromo::spectral {

Xyz xyz_of_light(const Spectrum& spd) {
  const Observer& o = cie1931_observer();
  return {(spd.values() * o.x_bar.values()).sum() * kGridStepNm,
          (spd.values() * o.y_bar.values()).sum() * kGridStepNm,
          (spd.values() * o.z_bar.values()).sum() * kGridStepNm};
}

Xyz white_point(const Spectrum& illuminant) {
  Xyz w = xyz_of_light(illuminant);
  const double k = 100.0 / w.Y;
  return {w.X * k, 100.0, w.Z * k};
}

Xyz xyz_of_reflectance(const Spectrum& reflectance, const Spectrum& illuminant) {
  const Observer& o = cie1931_observer();
  const double k = 100.0 / (illuminant.values() * o.y_bar.values()).sum();
  const GridArray stimulus = reflectance.values() * illuminant.values();
  return {k * (stimulus * o.x_bar.values()).sum(), k * (stimulus * o.y_bar.values()).sum(),
          k * (stimulus * o.z_bar.values()).sum()};
}

namespace {
constexpr double kEpsilon = 216.0 / 24389.0;  // (6/29)^3
constexpr double kKappa = 24389.0 / 27.0;
double lab_f(double t) { return t > kEpsilon ? std::cbrt(t) : (kKappa * t + 16.0) / 116.0; }
double lab_f_inverse(double f) {
  const double f3 = f * f * f;
  return f3 > kEpsilon ? f3 : (116.0 * f - 16.0) / kKappa;
}
}  // namespace

Lab lab_from_xyz(const Xyz& xyz, const Xyz& white) {
  const double fx = lab_f(xyz.X / white.X), fy = lab_f(xyz.Y / white.Y), fz = lab_f(xyz.Z / white.Z);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

Xyz xyz_from_lab(const Lab& lab, const Xyz& white) {
  const double fy = (lab.L + 16.0) / 116.0;
  const double fx = fy + lab.a / 500.0;
  const double fz = fy - lab.b / 200.0;
  return {white.X * lab_f_inverse(fx), white.Y * lab_f_inverse(fy), white.Z * lab_f_inverse(fz)};
}

Chromaticity chromaticity(const Xyz& xyz) {
  const double sum = xyz.X + xyz.Y + xyz.Z;
  return {xyz.X / sum, xyz.Y / sum};
}

UvPrime uv_prime(const Xyz& xyz) {
  const double d = xyz.X + 15.0 * xyz.Y + 3.0 * xyz.Z;
  return {4.0 * xyz.X / d, 9.0 * xyz.Y / d};
}

}  // namespace chromo::spectral
