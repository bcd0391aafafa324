#pragma once
// CIE reference data compiled in from data/ (see data/README.md for sources
// and licences), resampled onto the grid by resample.hpp's rule. Each accessor
// parses once and caches; all are thread-safe.

#include <string_view>

#include "chromo/spectral/spectrum.hpp"

namespace chromo::spectral {

namespace data {
// Text of a file compiled in from data/, keyed by its path relative to data/
// ("cie_d65.csv"). Throws std::out_of_range for an unknown name.
std::string_view embedded_file(std::string_view name);
}  // namespace data

struct Observer {
  Spectrum x_bar, y_bar, z_bar;
};

const Observer& cie1931_observer();
const Spectrum& illuminant_d65();
// IEC 62471 (CIE S 009) blue-light hazard weighting B(λ), dimensionless, 1 at
// 435-440 nm (data/blue_light_hazard_iec62471.csv).
const Spectrum& blue_light_hazard_weighting();
const Spectrum& illuminant_d50();
const Spectrum& illuminant_a();

// CIE daylight at correlated colour temperature cct_K (4000-25000 K), from the
// S0, S1, S2 basis (CIE 15:2004), normalised to 100 at 560 nm.
Spectrum daylight_illuminant(double cct_K);

// "d65", "d50", "a" (case-insensitive), else a CSV file path read with
// read_spectrum_file. DataError on an unknown name or bad file.
Spectrum illuminant_by_name_or_file(std::string_view name_or_path);

}  // namespace chromo::spectral
