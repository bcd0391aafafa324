// The LED lab's truth on a sphere with polariser banks (docs/polarisation.md):
// a bank emits its LEDs' light through the film, the unpolarised state both
// banks; a sphere without banks emits exactly as before.

#include <gtest/gtest.h>

#include "chromo/simulators/leds/led_lab.hpp"

namespace chromo::simulators {
namespace {

using drivers::Polarisation;

spectral::Spectrum settled_irradiance(LedLab& lab, Polarisation w57_state) {
  drivers::LedState state;
  state.drive[0] = 0.6;
  state.polarisation[0] = w57_state;
  EXPECT_EQ(lab.apply(state), LabResult::kOk);
  lab.set_output_enabled(true);
  lab.settle_thermal();
  return lab.irradiance_now();
}

TEST(LedLabPolarisation, ABankEmitsThroughItsFilmAndUnpolarisedDrivesBoth) {
  LedLabOptions plain_options, polarised_options;
  polarised_options.polariser_banks.fill(true);
  LedLab plain(plain_options), polarised(polarised_options);
  const spectral::Spectrum reference = settled_irradiance(plain, Polarisation::kUnpolarised);
  const PolariserFilm& film = polarised_options.polariser_film;
  for (Polarisation state : {Polarisation::kCross, Polarisation::kParallel, Polarisation::kUnpolarised}) {
    const spectral::Spectrum through = settled_irradiance(polarised, state);
    const double banks = state == Polarisation::kUnpolarised ? 2 : 1;
    for (int i = 0; i < spectral::kGridSize; ++i) {
      if (reference[i] < 1e-6 * reference.max()) continue;
      EXPECT_NEAR(through[i] / reference[i], banks * film.transmission_at(spectral::grid_wavelength_nm(i)), 1e-9)
          << drivers::polarisation_name(state) << " at " << spectral::grid_wavelength_nm(i) << " nm";
    }
    EXPECT_NEAR(polarised.irradiance_at_nm(550) / plain.irradiance_at_nm(550), banks * 0.42, 1e-9);
  }
}

TEST(LedLabPolarisation, ASphereWithoutBanksNeverAppliesTheFilm) {
  LedLabOptions other_film;
  other_film.polariser_film.transmission_550nm = 0.1;  // no banks: the film is never in the light
  LedLab a{LedLabOptions{}}, b{other_film};
  const spectral::Spectrum first = settled_irradiance(a, Polarisation::kUnpolarised);
  const spectral::Spectrum second = settled_irradiance(b, Polarisation::kUnpolarised);
  for (int i = 0; i < spectral::kGridSize; ++i) EXPECT_EQ(first[i], second[i]);
  drivers::LedState cross;
  cross.drive[0] = 0.6;
  cross.polarisation[0] = Polarisation::kCross;
  EXPECT_EQ(a.apply(cross), LabResult::kBadPolarisation);  // no bank: refused, nothing changed
  for (int i = 0; i < spectral::kGridSize; ++i) EXPECT_EQ(a.irradiance_now()[i], first[i]);
}

TEST(LedLabPolarisation, AnInvalidFilmIsRefusedAtConstruction) {
  LedLabOptions options;
  options.polariser_film.transmission_550nm = 0.8;  // above 0.5: not a polariser
  EXPECT_THROW(LedLab{options}, std::invalid_argument);
}

}  // namespace
}  // namespace chromo::simulators
