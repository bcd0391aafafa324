#pragma once
// The estimation benches' accuracy score: an estimate's skin relit under the
// six LED types and D65 (relight_illuminants()) against the truth's, mean
// ΔE94 per illuminant, and each parameter's mean error.

#include <cmath>
#include <span>
#include <vector>

#include "chromo/estimation/estimator.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/delta_e.hpp"

namespace chromo::bench {

// CIELAB of many albedos under the relight illuminants, computed once per set.
struct Relit {
  std::vector<std::vector<spectral::Lab>> lab;  // [illuminant][pixel]
};

inline Relit relight(std::span<const estimation::SkinParameters> p) {
  static const estimation::SkinModel model;
  std::vector<spectral::Spectrum> albedo(p.size());
  model.albedo_batch(p, albedo);
  Relit r;
  for (const spectral::NamedIlluminant& i : spectral::relight_illuminants()) {
    const spectral::Xyz white = spectral::white_point(i.spectrum);
    std::vector<spectral::Lab> lab(p.size());
    for (std::size_t k = 0; k < p.size(); ++k)
      lab[k] = spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo[k], i.spectrum), white);
    r.lab.push_back(std::move(lab));
  }
  return r;
}

struct Accuracy {
  double de_all = 0, de_d65 = 0;   // mean relit ΔE94: over six LEDs + D65, and D65 alone
  double de_led[7] = {};
  double log_cm = 0, log_ch = 0, bm = 0, che = 0;  // mean |error| (log10 for Cm, Ch)
  std::size_t pixels = 0;
};

// Accuracy over pixels where mask is set and the estimate is explained.
inline Accuracy accuracy(const Relit& truth, std::span<const estimation::SkinParameters> truth_p,
                         std::span<const estimation::PixelEstimate> e, const std::vector<bool>& mask) {
  std::vector<estimation::SkinParameters> est;
  std::vector<std::size_t> index;
  for (std::size_t i = 0; i < e.size(); ++i)
    if (mask[i] && e[i].flag == estimation::PixelFlag::kExplained) est.push_back(e[i].parameters), index.push_back(i);
  Accuracy a;
  a.pixels = est.size();
  if (est.empty()) return a;
  const Relit r = relight(est);
  for (std::size_t l = 0; l < r.lab.size(); ++l) {
    double sum = 0;
    for (std::size_t k = 0; k < est.size(); ++k) sum += spectral::delta_e94(truth.lab[l][index[k]], r.lab[l][k]);
    a.de_led[l] = sum / est.size();
    a.de_all += a.de_led[l] / r.lab.size();
  }
  a.de_d65 = a.de_led[6];
  for (std::size_t k = 0; k < est.size(); ++k) {
    const estimation::SkinParameters& t = truth_p[index[k]];
    a.log_cm += std::abs(std::log10(est[k].cm / t.cm)) / est.size();
    a.log_ch += std::abs(std::log10(est[k].ch / t.ch)) / est.size();
    a.bm += std::abs(est[k].bm - t.bm) / est.size();
    a.che += std::abs(est[k].che - t.che) / est.size();
  }
  return a;
}

// Mean relit ΔE94 under CIE A (not one of the relight illuminants) over
// pixels where mask is set and the estimate is explained.
inline double relit_under_a(std::span<const estimation::SkinParameters> truth,
                            std::span<const estimation::PixelEstimate> e, const std::vector<bool>& mask) {
  static const estimation::SkinModel model;
  const spectral::Spectrum& a = spectral::illuminant_a();
  const spectral::Xyz white = spectral::white_point(a);
  const auto lab = [&](const estimation::SkinParameters& p) {
    return spectral::lab_from_xyz(spectral::xyz_of_reflectance(model.albedo(p), a), white);
  };
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < e.size(); ++i)
    if (mask[i] && e[i].flag == estimation::PixelFlag::kExplained) sum += spectral::delta_e94(lab(truth[i]), lab(e[i].parameters)), ++n;
  return n ? sum / n : 0.0;
}

}  // namespace chromo::bench
