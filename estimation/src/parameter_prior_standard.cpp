// ParameterPrior::standard(): the prior learned from the NIST forearms' own
// full-spectrum fits. Apart from parameter_prior.cpp (and out of unity
// batches, estimation/CMakeLists.txt) because it calls fit_spectrum, i.e.
// Ceres: a program that uses the prior's arithmetic does not link Ceres.
#include <vector>

#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/parameter_prior.hpp"
#include "chromo/estimation/spectrum_fit.hpp"

namespace chromo::estimation {

std::shared_ptr<const ParameterPrior> ParameterPrior::standard() {
  static const std::shared_ptr<const ParameterPrior> learned = [] {
    const auto& spectra = nist_forearm_spectra();
    std::vector<SkinParameters> fits(spectra.size());
#pragma omp parallel for schedule(dynamic)
    for (std::size_t i = 0; i < spectra.size(); ++i) fits[i] = fit_spectrum(spectra[i].albedo).parameters;
    return std::make_shared<const ParameterPrior>(learn(fits));
  }();
  return learned;
}

}  // namespace chromo::estimation
