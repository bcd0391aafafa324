#include "chromo/estimation/layer_optics.hpp"

#include <algorithm>
#include <cmath>

namespace chromo::estimation {

double diffuse_fresnel_reflectance(double eta) { return -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta; }

double boundary_coefficient(double eta) {
  const double fdr = diffuse_fresnel_reflectance(eta);
  return (1.0 + fdr) / (1.0 - fdr);
}

namespace {

struct SlabGeometry {
  double alpha, sigma_tr, l, zb0, period;  // period = 2(d + z_b0 + z_bd)
};

SlabGeometry slab_geometry(double sigma_a, double sigma_s, double d, double a_entry, double a_exit) {
  const double sigma_t = sigma_a + sigma_s;
  const double diffusion = 1.0 / (3.0 * sigma_t);
  SlabGeometry g;
  g.alpha = sigma_s / sigma_t;
  g.sigma_tr = std::sqrt(3.0 * sigma_a * sigma_t);
  g.l = 1.0 / sigma_t;
  g.zb0 = 2.0 * a_entry * diffusion;
  g.period = 2.0 * (d + g.zb0 + 2.0 * a_exit * diffusion);
  return g;
}

// Σ over all integers i of sgn(z_i)·exp(-σtr|z_i|), z_i = i·period + c.
// With i0 the first index where z_i ≥ 0, z0 = z_i0 and q = exp(-σtr·period):
// the terms i ≥ i0 sum to x/(1-q) with x = exp(-σtr z0), the terms i < i0 to
// -(q/x)/(1-q). A pole exactly at z = 0 has sgn(0) = 0 and the lattice is
// then antisymmetric about it: the sum is 0.
double pole_family_sum(double sigma_tr, double period, double c) {
  const double i0 = std::ceil(-c / period);
  const double z0 = i0 * period + c;
  if (z0 == 0.0) return 0.0;
  const double x = std::exp(-sigma_tr * z0);
  const double q_over_x = std::exp(-sigma_tr * (period - z0));
  const double q = std::exp(-sigma_tr * period);
  return (x - q_over_x) / (1.0 - q);
}

double signed_term(double sigma_tr, double z) {
  if (z == 0.0) return 0.0;
  return std::copysign(std::exp(-sigma_tr * std::abs(z)), z);
}

}  // namespace

SlabReflectance multipole_slab(double sigma_a, double sigma_s, double d, double a_entry, double a_exit) {
  const SlabGeometry g = slab_geometry(sigma_a, sigma_s, d, a_entry, a_exit);
  const double half_alpha = 0.5 * g.alpha;
  // z_r,i = i·P + l, z_v,i = i·P - l - 2 z_b0 (R);
  // d - z_r,i and d - z_v,i run over the same lattice with offsets d - l and
  // d + l + 2 z_b0 (T; i → -i).
  const double r = pole_family_sum(g.sigma_tr, g.period, g.l) - pole_family_sum(g.sigma_tr, g.period, -g.l - 2.0 * g.zb0);
  const double t =
      pole_family_sum(g.sigma_tr, g.period, d - g.l) - pole_family_sum(g.sigma_tr, g.period, d + g.l + 2.0 * g.zb0);
  return {half_alpha * r, half_alpha * t};
}

SlabReflectance multipole_slab_explicit(double sigma_a, double sigma_s, double d, double a_entry, double a_exit,
                                        double tolerance, int* pole_pairs_used) {
  const SlabGeometry g = slab_geometry(sigma_a, sigma_s, d, a_entry, a_exit);
  // Adds the pole pair i to the sums; returns the largest single term's
  // magnitude (the stopping rule must not trust sums whose terms cancel).
  double r_sum = 0, t_sum = 0;
  auto add_pair = [&](int i) {
    const double zr = i * g.period + g.l;
    const double zv = i * g.period - g.l - 2.0 * g.zb0;
    const double terms[4] = {signed_term(g.sigma_tr, zr), signed_term(g.sigma_tr, zv),
                             signed_term(g.sigma_tr, d - zr), signed_term(g.sigma_tr, d - zv)};
    r_sum += terms[0] - terms[1];
    t_sum += terms[2] - terms[3];
    return std::max({std::abs(terms[0]), std::abs(terms[1]), std::abs(terms[2]), std::abs(terms[3])});
  };
  add_pair(0);
  int n = 0;
  constexpr int kMaxPairs = 100000;
  while (n < kMaxPairs) {
    ++n;
    const double largest = std::max(add_pair(n), add_pair(-n));
    if (0.5 * g.alpha * largest < tolerance) break;
  }
  if (pole_pairs_used) *pole_pairs_used = n;
  return {0.5 * g.alpha * r_sum, 0.5 * g.alpha * t_sum};
}

double dipole_semi_infinite(double sigma_a, double sigma_s, double a_top) {
  const double alpha = sigma_s / (sigma_a + sigma_s);
  const double root = std::sqrt(3.0 * (1.0 - alpha));
  return 0.5 * alpha * (1.0 + std::exp(-(4.0 / 3.0) * a_top * root)) * std::exp(-root);
}

}  // namespace chromo::estimation
