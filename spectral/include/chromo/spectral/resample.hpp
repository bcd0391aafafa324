#pragma once
// Tabulated spectrum → project grid, by MODEL.md's rule:
//  - tables sampled at 5 nm or coarser are interpolated linearly at each grid
//    wavelength;
//  - finer tables (1 nm CIE tables, 2 nm hemoglobin, spectrometer pixels,
//    narrow LEDs) are averaged: the grid value at λ is the mean of the samples
//    with wavelength in [λ-2.5, λ+2.5). A bin that holds no sample (a gap in an
//    irregular table) falls back to linear interpolation at λ.
// "Finer" means the median sample spacing is below 5 nm (minus 1e-9).
// The table must cover 380-780 nm unless `outside` says otherwise; wavelengths
// must be strictly increasing and values finite. Violations raise DataError.

#include <span>
#include <string_view>

#include "chromo/spectral/spectrum.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::spectral {

enum class OutsideRange {
  kError,  // a grid wavelength outside the table is an error (default)
  kZero,   // grid wavelengths outside the table get 0 (e.g. a filter curve)
};

Spectrum resample_to_grid(std::span<const double> wavelength_nm, std::span<const double> values,
                          std::string_view what, OutsideRange outside = OutsideRange::kError);

// Convenience: column `value_column` of `table` against its first column.
Spectrum resample_column(const Table& table, std::string_view value_column,
                         OutsideRange outside = OutsideRange::kError);

// A spectrum file in the project's convention: first column wavelength_nm,
// one value column (or the named one). Used for --illuminant FILE.csv etc.
Spectrum read_spectrum_file(const std::filesystem::path& path, std::string_view value_column = {});

}  // namespace chromo::spectral
