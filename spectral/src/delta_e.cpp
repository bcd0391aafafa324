#include "chromo/spectral/delta_e.hpp"

#include <cmath>
#include <numbers>

namespace chromo::spectral {

double delta_e76(const Lab& r, const Lab& s) { return std::hypot(r.L - s.L, r.a - s.a, r.b - s.b); }

double delta_e94(const Lab& reference, const Lab& sample) {
  constexpr double kK1 = 0.045, kK2 = 0.015;
  const double c_ref = std::hypot(reference.a, reference.b);
  const double c_sample = std::hypot(sample.a, sample.b);
  const double dL = reference.L - sample.L;
  const double dC = c_ref - c_sample;
  const double da = reference.a - sample.a, db = reference.b - sample.b;
  const double dH2 = std::max(0.0, da * da + db * db - dC * dC);
  const double sC = 1.0 + kK1 * c_ref, sH = 1.0 + kK2 * c_ref;
  return std::sqrt(dL * dL + (dC / sC) * (dC / sC) + dH2 / (sH * sH));
}

double delta_e00(const Lab& lab1, const Lab& lab2) {
  using std::atan2, std::cos, std::exp, std::pow, std::sin, std::sqrt;
  constexpr double kPi = std::numbers::pi;
  constexpr double kDeg = kPi / 180.0;
  const double c1 = std::hypot(lab1.a, lab1.b), c2 = std::hypot(lab2.a, lab2.b);
  const double c_mean = (c1 + c2) / 2.0;
  const double c7 = pow(c_mean, 7.0);
  const double g = 0.5 * (1.0 - sqrt(c7 / (c7 + pow(25.0, 7.0))));
  const double a1p = (1.0 + g) * lab1.a, a2p = (1.0 + g) * lab2.a;
  const double c1p = std::hypot(a1p, lab1.b), c2p = std::hypot(a2p, lab2.b);
  auto hue = [](double b, double ap) {
    if (b == 0.0 && ap == 0.0) return 0.0;
    double h = atan2(b, ap) / kDeg;
    return h < 0 ? h + 360.0 : h;
  };
  const double h1p = hue(lab1.b, a1p), h2p = hue(lab2.b, a2p);

  const double dLp = lab2.L - lab1.L;
  const double dCp = c2p - c1p;
  double dhp = 0.0;
  if (c1p * c2p != 0.0) {
    dhp = h2p - h1p;
    if (dhp > 180.0) dhp -= 360.0;
    else if (dhp < -180.0) dhp += 360.0;
  }
  const double dHp = 2.0 * sqrt(c1p * c2p) * sin(dhp * kDeg / 2.0);

  const double Lp_mean = (lab1.L + lab2.L) / 2.0;
  const double Cp_mean = (c1p + c2p) / 2.0;
  double hp_mean = h1p + h2p;
  if (c1p * c2p != 0.0) {
    if (std::abs(h1p - h2p) <= 180.0) hp_mean /= 2.0;
    else if (h1p + h2p < 360.0) hp_mean = (h1p + h2p + 360.0) / 2.0;
    else hp_mean = (h1p + h2p - 360.0) / 2.0;
  }
  const double t = 1.0 - 0.17 * cos((hp_mean - 30.0) * kDeg) + 0.24 * cos(2.0 * hp_mean * kDeg) +
                   0.32 * cos((3.0 * hp_mean + 6.0) * kDeg) - 0.20 * cos((4.0 * hp_mean - 63.0) * kDeg);
  const double d_theta = 30.0 * exp(-pow((hp_mean - 275.0) / 25.0, 2.0));
  const double cp7 = pow(Cp_mean, 7.0);
  const double rc = 2.0 * sqrt(cp7 / (cp7 + pow(25.0, 7.0)));
  const double l50 = (Lp_mean - 50.0) * (Lp_mean - 50.0);
  const double sl = 1.0 + 0.015 * l50 / sqrt(20.0 + l50);
  const double sc = 1.0 + 0.045 * Cp_mean;
  const double sh = 1.0 + 0.015 * Cp_mean * t;
  const double rt = -sin(2.0 * d_theta * kDeg) * rc;
  const double tl = dLp / sl, tc = dCp / sc, th = dHp / sh;
  return sqrt(tl * tl + tc * tc + th * th + rt * tc * th);
}

}  // namespace chromo::spectral
