#pragma once
// The LED spectral library: what each of the sphere's six LED types emits,
// measured with a spectrometer at a ladder of drive levels. It is the input
// of the mix solver (mix_solver.hpp) and of the estimator's lookup tables.
// File format: docs/formats/led-library.md (JSON); load/save in
// led_library_io.hpp. A plain value type: copy freely, no thread rules.
//
// Units: spectra are relative spectral irradiance at the sphere's sample
// plane ("library units"), on the project grid, already corrected by the
// spectrometer's relative spectral response (response_calibration.hpp) and,
// when `dark_subtracted`, with the dark spectrum removed. Only ratios between
// spectra of one library are meaningful; the mix solver is invariant to a
// common scale and (when no drive limit binds) to per-LED scales too.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "chromo/spectral/led_type.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::calibration {

using spectral::LedType;

// One rung of the drive ladder: the LED driven at drive_level (fraction of
// full scale, 0 < level ≤ 1) after warm-up.
struct LedSpectrumSample {
  double drive_level = 1.0;
  std::optional<double> led_temperature_C;    // heat-sink / board sensor; absent when not measured
  std::optional<double> integration_time_us;  // spectrometer integration time; absent for non-measured data
  bool dark_subtracted = true;
  spectral::Spectrum spectrum;
};

// How an LED's light changes with its temperature (the controller's board /
// junction sensor), from two spectra at one drive level: taken as the LED
// is switched on (cold) and after its warm-up (warm). A session corrects a
// capture whose LEDs ran at other temperatures than its white reference's
// with it (docs/calibration.md "Thermal coefficients").
struct LedThermalRecord {
  double drive_level = 1.0;
  double cold_C = 0;                      // mean of the sensor as the cold spectrum starts and as its light ends
  double warm_C = 0;                      // the sensor before the warm spectrum (settled)
  // Flux relative to the warm flux: Φ(T) = Φ_warm·(1 + flux_change_per_K·(T − warm_C)),
  // i.e. (1 − ∫cold/∫warm)/(warm_C − cold_C); LEDs dim as they warm: < 0.
  double flux_change_per_K = 0;
  double centroid_shift_nm_per_K = 0;     // (centroid warm − centroid cold)/(warm_C − cold_C)
};

struct LedRecord {
  LedType type = LedType::kW57;
  std::string description;                 // part number, what it is
  double max_drive_level = 1.0;            // drive limit the solver must respect (0 < max ≤ 1)
  std::vector<LedSpectrumSample> ladder;   // strictly increasing drive_level, at least one rung
  // Measured by a calibration run whose warm-up raised the sensor by at
  // least kMinThermalRiseK; absent otherwise (and in nominal libraries).
  std::optional<LedThermalRecord> thermal;

  // The spectrum per unit drive level: least-squares slope through the origin
  // of spectrum against drive over the ladder (Σ d·s / Σ d²). With one rung it
  // is spectrum/drive. This is the column the mix solver uses.
  spectral::Spectrum spectrum_per_unit_drive() const;
};

// The relative spectral response calibration the spectra were corrected
// with (response_calibration.hpp computes it; stored for traceability).
struct ResponseCalibrationRecord {
  std::string reference_lamp;        // e.g. "virtual-lab tungsten halogen #1"
  double lamp_temperature_K = 0;     // colour temperature the lamp was taken at
  std::string calibrated_utc;        // ISO 8601
  spectral::Spectrum correction;     // multiply raw counts by this (1 at 560 nm)
};

struct InstrumentInfo {
  std::string spectrometer_model;
  std::string spectrometer_serial;
  std::optional<ResponseCalibrationRecord> response_calibration;  // absent: spectra not response-corrected by us
};

struct MeasurementConditions {
  std::optional<double> ambient_temperature_C;
  std::optional<double> warm_up_s;
  std::string notes;
};

struct LedLibrary {
  std::string source;        // "measured" (a calibration run) or "nominal" (built-in datasheet-class spectra)
  std::string created_utc;   // ISO 8601, e.g. 2026-11-22T16:00:00Z
  InstrumentInfo instrument;
  MeasurementConditions conditions;
  std::array<LedRecord, spectral::kLedTypeCount> leds;  // indexed by led_type_index()

  const LedRecord& led(LedType type) const { return leds[spectral::led_type_index(type)]; }
  LedRecord& led(LedType type) { return leds[spectral::led_type_index(type)]; }
};

// Empty when the library is well-formed (every LED type once, in order,
// ladders non-empty, drive levels in (0, 1] and strictly increasing, spectra
// finite, not all zero and within ±kMaxLibrarySpectrumValue, drive limits in
// (0, 1], positive integration times); otherwise a message naming the LED and
// field at fault.
inline constexpr double kMaxLibrarySpectrumValue = 1e12;
std::string validate(const LedLibrary& library);

// The built-in library, so the solver and CLI work before any measurement:
// the six measured spectra compiled into spectral/ (data/led_spectra_measured,
// Aphalo's photobiologyLEDs: W57 LCFOCUS LC-10FS504-G24, W40 LCFOCUS
// LC-10FSCOB1917-4000, W27 Nichia NS6L183AT-H1, R/G/B LED Engin LZ7-N4M100
// channels B/A/C), resampled to the grid by MODEL.md's rule, each scaled so
// that at full drive its radiant flux (∫ s dλ, library units·nm) is
// kNominalRadiantFlux[type]: 1.0 for each 10 W white COB, 0.3 for each 3 W
// colour die. One rung at drive 1.0, no temperature or integration time
// (not measured by us), source "nominal".
inline constexpr std::array<double, spectral::kLedTypeCount> kNominalRadiantFlux{1.0, 1.0, 1.0, 0.3, 0.3, 0.3};
LedLibrary nominal_led_library();

}  // namespace chromo::calibration
