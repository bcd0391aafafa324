#include "chromo/calibration/led_library.hpp"

#include <algorithm>
#include <sstream>

#include <cmath>
#include <string>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {

spectral::Spectrum LedRecord::spectrum_per_unit_drive() const {
  spectral::Spectrum weighted_sum;
  double drive_squared = 0;
  for (const LedSpectrumSample& sample : ladder) {
    weighted_sum += sample.spectrum * sample.drive_level;
    drive_squared += sample.drive_level * sample.drive_level;
  }
  return drive_squared > 0 ? weighted_sum / drive_squared : weighted_sum;
}

std::optional<double> LedRecord::ladder_temperature_C() const {
  double weighted_sum = 0, drive_squared = 0;
  for (const LedSpectrumSample& sample : ladder) {
    if (!sample.led_temperature_C) return std::nullopt;
    weighted_sum += *sample.led_temperature_C * sample.drive_level * sample.drive_level;
    drive_squared += sample.drive_level * sample.drive_level;
  }
  if (!(drive_squared > 0)) return std::nullopt;
  return weighted_sum / drive_squared;
}

spectral::Spectrum LedRecord::spectrum_at(double temperature_C) const {
  const spectral::Spectrum reference = spectrum_per_unit_drive();
  const std::optional<double> reference_C = ladder_temperature_C();
  if (!thermal || !reference_C || !std::isfinite(temperature_C)) return reference;
  const double shift_nm = thermal->centroid_shift_nm_per_K * (temperature_C - *reference_C);
  // The emission at λ is the reference's at λ − shift: the reference's
  // samples placed at grid + shift, read back on the grid.
  std::vector<double> shifted_nm(spectral::kGridSize);
  for (int i = 0; i < spectral::kGridSize; ++i) shifted_nm[i] = spectral::grid_wavelength_nm(i) + shift_nm;
  const spectral::Spectrum out = spectral::resample_to_grid(shifted_nm, reference.to_vector(), "LED spectrum at temperature",
                                                            spectral::OutsideRange::kZero);
  return out * flux_factor_at(temperature_C);
}

double LedRecord::flux_factor_at(double temperature_C) const {
  const std::optional<double> reference_C = ladder_temperature_C();
  if (!thermal || !reference_C || !std::isfinite(temperature_C)) return 1.0;
  return std::max(0.0, 1.0 + thermal->flux_change_per_K * (temperature_C - *reference_C));
}

std::string validate(const LedLibrary& library) {
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    const LedRecord& led = library.leds[i];
    const std::string where = "leds[" + std::to_string(i) + "]";
    if (spectral::led_type_index(led.type) != i)
      return where + ".type: expected " + std::string(spectral::led_type_name(spectral::kAllLedTypes[i])) + ", got " +
             std::string(spectral::led_type_name(led.type)) + " (one record per type, in the order W57,W40,W27,R,G,B)";
    const std::string name(spectral::led_type_name(led.type));
    if (!(led.max_drive_level > 0.0 && led.max_drive_level <= 1.0))
      return name + ".max_drive_level = " + std::to_string(led.max_drive_level) + " is outside (0, 1]";
    if (led.ladder.empty()) return name + ".ladder is empty (at least one drive level is needed)";
    double previous = 0;
    for (std::size_t k = 0; k < led.ladder.size(); ++k) {
      const LedSpectrumSample& s = led.ladder[k];
      const std::string rung = name + ".ladder[" + std::to_string(k) + "]";
      if (!(s.drive_level > previous && s.drive_level <= 1.0))
        return rung + ".drive_level = " + std::to_string(s.drive_level) +
               " must be in (0, 1] and above the previous rung's";
      previous = s.drive_level;
      if (s.integration_time_us && !(*s.integration_time_us > 0.0 && std::isfinite(*s.integration_time_us)))
        return rung + ".integration_time_us must be positive";
      if (s.led_temperature_C && !std::isfinite(*s.led_temperature_C))
        return rung + ".led_temperature_C must be finite";
      if (!s.spectrum.values().allFinite()) return rung + ".spectrum holds a non-finite value";
      // Library units are arbitrary, but a value beyond this is a unit mistake
      // or a hostile file: the solver's sums of squares would overflow.
      if (s.spectrum.values().abs().maxCoeff() > kMaxLibrarySpectrumValue)
        return rung + ".spectrum holds " + (std::ostringstream() << s.spectrum.values().abs().maxCoeff()).str() +
               ", beyond the 1e12 cap on |value| (library units)";
      if (!(s.spectrum.values().abs().maxCoeff() > 0.0)) return rung + ".spectrum is all zero";
    }
  }
  return {};
}

LedLibrary nominal_led_library() {
  static const LedLibrary library = [] {
    struct Source {
      const char* file;
      const char* description;
    };
    constexpr std::array<Source, spectral::kLedTypeCount> kSources{{
        {"led_spectra_measured/LCFOCUS_LC_10FS504_G24.csv", "LCFOCUS LC-10FS504-G24 10 W cool white COB (~5700 K)"},
        {"led_spectra_measured/LCFOCUS_LC_10FSCOB1917_4000.csv", "LCFOCUS LC-10FSCOB1917-4000 10 W neutral white COB"},
        {"led_spectra_measured/Nichia_NS6L183AT_H1_sw.csv", "Nichia NS6L183AT-H1 warm white (~2700 K)"},
        {"led_spectra_measured/LedEngin_LZ7_N4M100_ch_B_Red.csv", "LED Engin LZ7-N4M100 channel B (red, 629 nm)"},
        {"led_spectra_measured/LedEngin_LZ7_N4M100_ch_A_Green.csv", "LED Engin LZ7-N4M100 channel A (green, 519 nm)"},
        {"led_spectra_measured/LedEngin_LZ7_N4M100_ch_C_Blue.csv", "LED Engin LZ7-N4M100 channel C (blue, 454 nm)"},
    }};
    LedLibrary lib;
    lib.source = "nominal";
    lib.created_utc = "2022-05-10T23:03:46Z";  // date of the newest of the six source measurements
    lib.instrument.spectrometer_model = "Ocean Optics Maya 2000 Pro with Bentham D7H cosine diffuser (P. J. Aphalo)";
    lib.instrument.spectrometer_serial = "unknown";
    lib.conditions.notes =
        "built-in nominal library: published spectra (photobiologyLEDs 0.5.3), LED current 350 mA, resampled to "
        "380-780 nm/5 nm and scaled to the nominal radiant flux of kNominalRadiantFlux";
    for (int i = 0; i < spectral::kLedTypeCount; ++i) {
      const std::string name = kSources[i].file;
      const spectral::Table table = spectral::parse_table(spectral::data::embedded_file(name), "data/" + name);
      spectral::Spectrum s = spectral::resample_column(table, "relative_spectral_irradiance");
      s = s * (kNominalRadiantFlux[i] / s.integral());
      LedRecord& led = lib.leds[i];
      led.type = spectral::kAllLedTypes[i];
      led.description = kSources[i].description;
      led.ladder = {LedSpectrumSample{1.0, std::nullopt, std::nullopt, true, s}};
    }
    return lib;
  }();
  return library;
}

}  // namespace chromo::calibration
