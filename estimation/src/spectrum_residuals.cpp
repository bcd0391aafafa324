// fit_residuals (model_discrepancy.hpp): the only part of the discrepancy
// that fits spectra, and so the only one that needs Ceres. It is its own
// object (not in a unity batch, estimation/CMakeLists.txt) so that a program
// reading the shipped residuals or the NIST spectra links no Ceres.
#include <omp.h>

#include <exception>

#include "chromo/estimation/model_discrepancy.hpp"

namespace chromo::estimation {

std::vector<SpectrumResidual> fit_residuals(std::span<const NamedSpectrum> spectra, const SpectrumFitOptions& options,
                                            int threads) {
  std::vector<SpectrumResidual> out(spectra.size());
  std::vector<std::exception_ptr> errors(spectra.size());
  const int count = static_cast<int>(spectra.size());
#pragma omp parallel for schedule(dynamic) num_threads(threads > 0 ? threads : omp_get_max_threads())
  for (int i = 0; i < count; ++i) {
    try {
      const SpectrumFitResult fit = fit_spectrum(spectra[i].albedo, options);
      out[i].name = spectra[i].name;
      out[i].fitted = fit.fitted;
      out[i].residual = spectral::Spectrum(spectra[i].albedo.values() - fit.fitted.values());
    } catch (...) {
      errors[i] = std::current_exception();
    }
  }
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  return out;
}

}  // namespace chromo::estimation
