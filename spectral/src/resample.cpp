#include "chromo/spectral/resample.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace chromo::spectral {
namespace {

double interpolate(std::span<const double> x, std::span<const double> y, double at) {
  auto upper = std::upper_bound(x.begin(), x.end(), at);
  if (upper == x.begin()) return y.front();
  if (upper == x.end()) return y.back();
  std::size_t hi = static_cast<std::size_t>(upper - x.begin());
  std::size_t lo = hi - 1;
  double t = (at - x[lo]) / (x[hi] - x[lo]);
  return y[lo] + t * (y[hi] - y[lo]);
}

}  // namespace

Spectrum resample_to_grid(std::span<const double> wavelength_nm, std::span<const double> values,
                          std::string_view what, OutsideRange outside) {
  const std::string name(what);
  if (wavelength_nm.size() != values.size())
    throw DataError(name + ": " + std::to_string(wavelength_nm.size()) + " wavelengths but " +
                    std::to_string(values.size()) + " values");
  if (wavelength_nm.size() < 2) throw DataError(name + ": needs at least two samples");
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(wavelength_nm[i]) || !std::isfinite(values[i]))
      throw DataError(name + ": sample " + std::to_string(i) + " is not finite");
    if (i > 0 && !(wavelength_nm[i] > wavelength_nm[i - 1]))
      throw DataError(name + ": wavelengths must increase strictly (" + std::to_string(wavelength_nm[i - 1]) +
                      " then " + std::to_string(wavelength_nm[i]) + " nm)");
  }
  const double first = wavelength_nm.front();
  const double last = wavelength_nm.back();
  if (outside == OutsideRange::kError && (first > kGridStartNm + 1e-9 || last < kGridEndNm - 1e-9)) {
    throw DataError(name + ": covers " + std::to_string(first) + "-" + std::to_string(last) +
                    " nm, but the grid needs 380-780 nm");
  }

  std::vector<double> spacing(wavelength_nm.size() - 1);
  for (std::size_t i = 0; i + 1 < wavelength_nm.size(); ++i) spacing[i] = wavelength_nm[i + 1] - wavelength_nm[i];
  std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
  const bool finer_than_grid = spacing[spacing.size() / 2] < kGridStepNm - 1e-9;

  Spectrum result;
  for (int g = 0; g < kGridSize; ++g) {
    const double lambda = grid_wavelength_nm(g);
    if (lambda < first - 1e-9 || lambda > last + 1e-9) {
      result[g] = 0.0;  // only reachable with OutsideRange::kZero
      continue;
    }
    if (finer_than_grid) {
      const double lo = lambda - kGridStepNm / 2, hi = lambda + kGridStepNm / 2;
      auto begin = std::lower_bound(wavelength_nm.begin(), wavelength_nm.end(), lo);
      auto end = std::lower_bound(wavelength_nm.begin(), wavelength_nm.end(), hi);
      if (end > begin) {
        double sum = 0;
        for (auto it = begin; it != end; ++it) sum += values[static_cast<std::size_t>(it - wavelength_nm.begin())];
        result[g] = sum / static_cast<double>(end - begin);
        continue;
      }
    }
    result[g] = interpolate(wavelength_nm, values, lambda);
  }
  return result;
}

Spectrum resample_column(const Table& table, std::string_view value_column, OutsideRange outside) {
  return resample_to_grid(table.columns.front(), table.column(value_column),
                          table.source + " column " + std::string(value_column), outside);
}

Spectrum read_spectrum_file(const std::filesystem::path& path, std::string_view value_column) {
  Table table = read_table(path);
  if (value_column.empty()) {
    if (table.column_names.size() != 2)
      throw DataError(path.string() + ": expected two columns (wavelength_nm, value), found " +
                      std::to_string(table.column_names.size()));
    value_column = table.column_names[1];
  }
  return resample_column(table, value_column);
}

}  // namespace chromo::spectral
