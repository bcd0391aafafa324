// fit_spectrum on the NIST forearm spectra (data/test): the 2D model and the
// spectral weighting. The 4D targets are asserted through the CLI
// (tests/cli/estimate_command_test.cpp, FitSpectrumCommand).
#include "chromo/estimation/spectrum_fit.hpp"

#include <gtest/gtest.h>

#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::estimation {
namespace {

std::vector<spectral::Spectrum> nist_forearms(std::size_t count) {
  const spectral::Table table = spectral::read_table(std::string(CHROMO_DATA_DIR) + "/skin_reflectance_nist.csv");
  std::vector<spectral::Spectrum> out;
  for (std::size_t c = 1; c < table.column_names.size() && out.size() < count; ++c)
    out.push_back(spectral::resample_column(table, table.column_names[c]));
  return out;
}

// The 2D model (βm = 0.7, Che = 0) misses real skin by about 2 ΔE94 under D65
// (issue 6; measured 1.68 over the 50 subjects).
TEST(SpectrumFit, TwoDModelMissesRealSkinByAboutTwoUnderD65) {
  SpectrumFitOptions o;
  o.order = 2;
  double d65 = 0;
  const auto spectra = nist_forearms(50);
  for (const auto& s : spectra) d65 += fit_spectrum(s, o).de94_d65 / spectra.size();
  EXPECT_GT(d65, 1.3);
  EXPECT_LT(d65, 2.2);
}

// Weighting the spectral term by the colour-forming band moves error out of
// the A and LED colours (over the first 12 subjects; all 50 in docs/estimation-notes.md section 3).
TEST(SpectrumFit, ColourBandWeightingBeatsFlatUnderAAndTheLeds) {
  const auto spectra = nist_forearms(12);
  SpectrumFitOptions band, flat;
  flat.spectral_weighting = SpectralWeighting::kFlat;
  double a_band = 0, a_flat = 0, led_band = 0, led_flat = 0;
  for (const auto& s : spectra) {
    const SpectrumFitResult b = fit_spectrum(s, band), f = fit_spectrum(s, flat);
    a_band += b.de94_a, a_flat += f.de94_a, led_band += b.de94_led_mean, led_flat += f.de94_led_mean;
  }
  EXPECT_LT(a_band, a_flat);
  EXPECT_LT(led_band, led_flat);
}

}  // namespace
}  // namespace chromo::estimation
