#include "chromo/estimation/skin_model.hpp"

#include <omp.h>

#include <limits>
#include <stdexcept>

#include "chromo/estimation/layer_optics.hpp"

namespace chromo::estimation {

using spectral::GridArray;
using spectral::Spectrum;

namespace {

// Vectorised form of layer_optics.cpp's pole_family_sum over the grid, for
// the epidermis' geometry. z0 is the family's first non-negative pole,
// x = exp(-σtr·z0) and q = exp(-σtr·P) is shared by the four families;
// q/x = exp(-σtr·(P - z0)) is formed by a division (x ≥ q, and q does not
// underflow for any parameters in MODEL.md's ranges), so each family costs
// one exponential. A pole exactly at z = 0 contributes sgn(0) = 0 and the
// lattice is then antisymmetric about it: the family sums to 0.
GridArray pole_family_sum(const GridArray& sigma_tr, const GridArray& q, const GridArray& one_minus_q_inverse,
                          const GridArray& z0) {
  const GridArray x = (-sigma_tr * z0).exp().max(std::numeric_limits<double>::min());
  return (z0 == 0.0).select(GridArray::Zero(), (x - q / x) * one_minus_q_inverse);
}

struct Evaluation {
  GridArray r1, t1, r2, albedo;
};

Evaluation evaluate(const ChromophoreSpectra& k, double skin_air_a, const SkinParameters& p) {
  Evaluation e;
  const double d = kEpidermisThicknessMm;
  // Epidermis: multipole slab, entry at the skin-air boundary, exit index-matched.
  const GridArray sigma_a_epi = p.cm * (p.bm * k.sigma_a_eumelanin.values() + (1.0 - p.bm) * k.sigma_a_pheomelanin.values()) +
                                p.che * k.sigma_a_blood.values() + (1.0 - p.cm - p.che) * k.sigma_a_baseline.values();
  const GridArray& sigma_s_epi = k.sigma_s_reduced_epidermis.values();
  const GridArray sigma_t_epi = sigma_a_epi + sigma_s_epi;
  const GridArray l = sigma_t_epi.inverse();
  const GridArray diffusion = l / 3.0;
  const GridArray sigma_tr = (3.0 * sigma_a_epi * sigma_t_epi).sqrt();
  const GridArray zb0 = 2.0 * skin_air_a * diffusion;
  const GridArray period = 2.0 * (d + zb0 + 2.0 * kIndexMatchedA * diffusion);
  const GridArray half_alpha = 0.5 * sigma_s_epi * l;
  const GridArray q = (-sigma_tr * period).exp();
  const GridArray one_minus_q_inverse = (1.0 - q).inverse();
  auto family = [&](const GridArray& z0) { return pole_family_sum(sigma_tr, q, one_minus_q_inverse, z0); };
  // First non-negative pole of each family (layer_optics.cpp finds it with a
  // ceil; here it is known): with the exit index-matched, z_bd = (2/3)·l, so
  // P = 2d + 2z_b0 + (4/3)l, and
  //   R, real  (c = l):             z0 = l
  //   R, image (c = -l - 2z_b0):    z0 = P - l - 2z_b0 = 2d + l/3 > 0
  //   T, real  (c = d - l):         z0 = d - l, or P + d - l when l > d
  //   T, image (c = d + l + 2z_b0): z0 = c < P
  const GridArray d_minus_l = d - l;
  e.r1 = half_alpha * (family(l) - family(period - l - 2.0 * zb0));
  e.t1 = half_alpha * (family((d_minus_l < 0.0).select(period + d_minus_l, d_minus_l)) - family(d + l + 2.0 * zb0));

  // Dermis: semi-infinite dipole with an index-matched top.
  const GridArray sigma_a_derm = p.ch * k.sigma_a_blood.values() + (1.0 - p.ch) * k.sigma_a_baseline.values();
  const GridArray& sigma_s_derm = k.sigma_s_reduced_dermis.values();
  const GridArray alpha_derm = sigma_s_derm / (sigma_a_derm + sigma_s_derm);
  const GridArray root = (3.0 * (1.0 - alpha_derm)).sqrt();
  e.r2 = 0.5 * alpha_derm * (1.0 + (-(4.0 / 3.0) * kIndexMatchedA * root).exp()) * (-root).exp();

  e.albedo = e.r1 + e.t1 * e.r2 * e.t1 / (1.0 - e.r1 * e.r2);
  return e;
}

}  // namespace

SkinModel::SkinModel() : chromophores_(chromophore_spectra()), skin_air_a_(boundary_coefficient(kSkinRefractiveIndex)) {}

Spectrum SkinModel::albedo(const SkinParameters& parameters) const {
  return Spectrum(evaluate(chromophores_, skin_air_a_, parameters).albedo);
}

LayerSpectra SkinModel::layers(const SkinParameters& parameters) const {
  const Evaluation e = evaluate(chromophores_, skin_air_a_, parameters);
  return {Spectrum(e.r1), Spectrum(e.t1), Spectrum(e.r2), Spectrum(e.albedo)};
}

void SkinModel::albedo_batch(std::span<const SkinParameters> parameters, std::span<Spectrum> out, int threads) const {
  if (parameters.size() != out.size())
    throw std::invalid_argument("albedo_batch: " + std::to_string(parameters.size()) + " parameter sets but room for " +
                                std::to_string(out.size()) + " spectra");
  const int thread_count = threads > 0 ? threads : omp_get_num_procs();
  const auto count = static_cast<std::ptrdiff_t>(parameters.size());
#pragma omp parallel for num_threads(thread_count) schedule(static) if (count > 64)
  for (std::ptrdiff_t i = 0; i < count; ++i) out[i].values() = evaluate(chromophores_, skin_air_a_, parameters[i]).albedo;
}

}  // namespace chromo::estimation
