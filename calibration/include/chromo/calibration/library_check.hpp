#pragma once
// The closed-loop check of an LED library before a daemon adopts it (issue
// 40): each candidate library's session mixes driven on the LEDs as they
// are now and measured with the spectrometer, so that a new calibration is
// compared with the library it would replace on the same light, the same
// minute, the same instrument.
//
// Per mix, two kinds of figure (mix_figures: Δu'v', camera ColorChecker
// ΔE00, spectral RMSE / max):
//  - prediction: the library's own prediction of the mix (Σ w·column)
//    against the measured spectrum. This is what the estimator assumes the
//    light to be: a library that mispredicts its light mispredicts every
//    relit product and map made under it;
//  - target (d65 only): the measured mix against D65, judged on what the
//    session mixes are solved for (camera objective: Δu'v' and camera ΔE00;
//    not the spectral RMSE, which the camera objective trades away).
// Spectra are compared at one brightness (each scaled to unit ∫), so a
// library in other units (the nominal one) is judged on shape alone.
//
// The verdict (LibraryComparison::candidate_no_worse) allows small margins
// (noise of one spectrometer reading): Δu'v' +0.0005, camera ΔE00 mean
// +0.05, RMSE +0.005.
#include <string>
#include <vector>

#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/mix_solver.hpp"
#include "chromo/drivers/led_controller.hpp"
#include "chromo/drivers/spectrometer.hpp"
#include "chromo/drivers/spectrometer_reader.hpp"

namespace chromo::calibration {

// One library's session mixes, as the daemon would drive them.
struct LibraryUnderCheck {
  std::string name;  // for messages: "new calibration 2026…", "the library in use (nominal, built-in)"
  const LedLibrary* library = nullptr;  // its prediction (columns); required
  std::vector<std::pair<std::string, drivers::DriveLevels>> mixes;  // "d65", "w57+blue:8", ... and their weights
};

struct MixCheck {
  std::string mix;
  drivers::DriveLevels weights{};
  spectral::Spectrum measured;    // response-corrected, unit ∫
  MixFigures prediction;          // the library's prediction against the measurement
  std::optional<MixFigures> target;  // d65: the measurement against D65
};

struct LibraryCheck {
  std::string name;
  std::vector<MixCheck> mixes;
};

struct LibraryComparison {
  LibraryCheck in_use, candidate;
  bool candidate_no_worse = true;
  // One line per figure where the candidate is worse beyond its margin
  // ("w57+blue:8 prediction camera ΔE00 0.42 against 0.18"); empty when no worse.
  std::vector<std::string> worse;
  // One paragraph for the record and the operator.
  std::string BriefReport() const;
};

struct LibraryCheckOptions {
  MixSolverOptions figures;  // camera and chart of the figures (camera objective's defaults)
  drivers::SpectrometerReaderOptions reader;
  double settle_s = 0.05;  // after each weight change (wall clock)
  double delta_uv_prime_margin = 0.0005;
  double camera_de00_margin = 0.05;
  double rmse_margin = 0.005;
};

// Drives each mix of both libraries on `leds` (output switched off at the
// end, whatever happens), measures it with `spectrometer` × `correction`
// (the instrument's response correction, e.g. the new run's), and compares.
// Throws drivers::DeviceError from the devices, std::invalid_argument for a
// library without columns or a mix of the candidate missing from in_use.
LibraryComparison compare_libraries_on_leds(drivers::LedController& leds, drivers::Spectrometer& spectrometer,
                                            const spectral::Spectrum& correction, const LibraryUnderCheck& in_use,
                                            const LibraryUnderCheck& candidate, const LibraryCheckOptions& options = {});

}  // namespace chromo::calibration
