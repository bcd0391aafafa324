#include "chromo/spectral/srgb.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "chromo/spectral/cie.hpp"

namespace chromo::spectral {
namespace {

const Eigen::Matrix3d& bradford() {
  static const Eigen::Matrix3d m = (Eigen::Matrix3d() << 0.8951, 0.2664, -0.1614,  //
                                    -0.7502, 1.7135, 0.0367,                       //
                                    0.0389, -0.0685, 1.0296)
                                       .finished();
  return m;
}

Eigen::Vector3d vec(const Xyz& x) { return {x.X, x.Y, x.Z}; }

}  // namespace

Xyz bradford_adapt(const Xyz& xyz, const Xyz& source_white, const Xyz& destination_white) {
  const Eigen::Vector3d cone_src = bradford() * vec(source_white);
  const Eigen::Vector3d cone_dst = bradford() * vec(destination_white);
  const Eigen::Vector3d cone = bradford() * vec(xyz);
  const Eigen::Vector3d adapted = bradford().inverse() * (cone.array() * cone_dst.array() / cone_src.array()).matrix();
  return {adapted.x(), adapted.y(), adapted.z()};
}

Rgb linear_srgb_from_xyz(const Xyz& xyz_y100, const Xyz& illuminant_white_y100) {
  static const Xyz d65_white = white_point(illuminant_d65());
  const Xyz adapted = bradford_adapt(xyz_y100, illuminant_white_y100, d65_white);
  const double X = adapted.X / 100.0, Y = adapted.Y / 100.0, Z = adapted.Z / 100.0;
  return {3.2406 * X - 1.5372 * Y - 0.4986 * Z,  //
          -0.9689 * X + 1.8758 * Y + 0.0415 * Z,  //
          0.0557 * X - 0.2040 * Y + 1.0570 * Z};
}

double srgb_encode(double linear) {
  if (linear <= 0.0031308) return 12.92 * linear;
  return 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

Rgb srgb_from_xyz(const Xyz& xyz_y100, const Xyz& illuminant_white_y100) {
  const Rgb lin = linear_srgb_from_xyz(xyz_y100, illuminant_white_y100);
  auto enc = [](double v) { return std::clamp(srgb_encode(v), 0.0, 1.0); };
  return {enc(lin.r), enc(lin.g), enc(lin.b)};
}

}  // namespace chromo::spectral
