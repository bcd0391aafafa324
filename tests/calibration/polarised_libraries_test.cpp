// LED libraries and mixes per polarisation state (docs/polarisation.md,
// "Calibration per state"): a polariser bank's spectra differ from the
// unpolarised ones by the film's transmission, so every state needs its own
// mix; reusing the unpolarised weights under the cross state misses D65.

#include <gtest/gtest.h>

#include <cstdio>

#include "chromo/calibration/polarised_libraries.hpp"
#include "chromo/simulators/polarisation/polariser_optics.hpp"

namespace chromo::calibration {
namespace {

using drivers::Polarisation;

spectral::Spectrum film_transmission() {  // the virtual lab's default film: 0.42 at 550 nm, 0.30 at 400 nm
  const simulators::PolariserFilm film;
  spectral::Spectrum t;
  for (int i = 0; i < spectral::kGridSize; ++i) t[i] = film.transmission_at(spectral::grid_wavelength_nm(i));
  return t;
}

int grid_index_nm(double nm) { return static_cast<int>((nm - spectral::kGridStartNm) / spectral::kGridStepNm + 0.5); }

TEST(PolarisedLibraries, ABanksLibraryIsTheUnpolarisedOneThroughTheFilm) {
  const LedLibrary unpolarised = nominal_led_library();
  const LedLibrary cross = library_through_polariser(unpolarised, film_transmission());
  EXPECT_EQ(validate(cross), "");
  EXPECT_EQ(cross.source, "nominal through polariser");
  const auto& before = unpolarised.led(LedType::kBlue).ladder[0].spectrum;
  const auto& after = cross.led(LedType::kBlue).ladder[0].spectrum;
  EXPECT_NEAR(after[grid_index_nm(550)] / before[grid_index_nm(550)], 0.42, 1e-12);
  EXPECT_NEAR(after[grid_index_nm(450)] / before[grid_index_nm(450)], 0.34, 1e-12);
  spectral::Spectrum bad = film_transmission();
  bad[grid_index_nm(400)] = 0;
  try {
    library_through_polariser(unpolarised, bad);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("400.000000 nm"), std::string::npos) << e.what();
  }
  PolarisedLedLibraries libraries;
  libraries.unpolarised = unpolarised;
  EXPECT_EQ(&libraries.for_state(Polarisation::kUnpolarised), &*libraries.unpolarised);
  try {
    libraries.for_state(Polarisation::kCross);
    ADD_FAILURE() << "no cross library, yet one was returned";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cross"), std::string::npos) << e.what();
  }
}

TEST(PolarisedLibraries, EveryStateGetsItsOwnD65MixAndReusingTheUnpolarisedWeightsMissesIt) {
  PolarisedLedLibraries libraries;
  libraries.unpolarised = nominal_led_library();
  libraries.cross = library_through_polariser(*libraries.unpolarised, film_transmission());
  libraries.parallel = libraries.cross;  // the same film, rotated by 90 degrees
  MixSolverOptions options;
  options.objective = MixObjective::kCamera;
  options.hold_chromaticity = true;
  const auto mixes = solve_mix_per_state(libraries, [](const LedLibrary&) { return d65_target(); }, options);
  ASSERT_EQ(mixes.size(), 3u);
  const MixSummary& plain = mixes.at(Polarisation::kUnpolarised);
  const MixSummary& cross = mixes.at(Polarisation::kCross);
  ASSERT_TRUE(plain.IsSolutionUsable()) << plain.message;
  ASSERT_TRUE(cross.IsSolutionUsable()) << cross.message;
  // The unpolarised weights under the cross banks: what a sphere without per-state mixes would show.
  spectral::Spectrum reused;
  for (LedType type : spectral::kAllLedTypes)
    reused += libraries.cross->led(type).spectrum_per_unit_drive() * plain.weights[led_type_index(type)];
  const MixFigures reused_figures = mix_figures(cross.target, reused, options);
  std::printf("D65' unpolarised: du'v' %.5f, camera dE00 %.3f; cross (own mix): du'v' %.5f, dE00 %.3f; "
              "cross with the unpolarised weights: du'v' %.5f, dE00 %.3f\n",
              plain.delta_uv_prime, plain.camera_de00.mean, cross.delta_uv_prime, cross.camera_de00.mean,
              reused_figures.delta_uv_prime, reused_figures.camera_de00.mean);
  EXPECT_LT(cross.delta_uv_prime, 0.002);
  EXPECT_GT(reused_figures.delta_uv_prime, 5 * std::max(cross.delta_uv_prime, 1e-3));
  // The film takes more in the blue: the cross mix drives blue harder relative to red.
  const int blue = led_type_index(LedType::kBlue), red = led_type_index(LedType::kRed);
  ASSERT_GT(plain.weights[red], 0);
  ASSERT_GT(cross.weights[red], 0);
  EXPECT_GT(cross.weights[blue] / cross.weights[red], plain.weights[blue] / plain.weights[red]);
  EXPECT_EQ(mixes.at(Polarisation::kParallel).weights, cross.weights);
}

}  // namespace
}  // namespace chromo::calibration
