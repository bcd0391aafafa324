#include "chromo/spectral/spectrum.hpp"

#include <stdexcept>
#include <string>

namespace chromo::spectral {

Spectrum Spectrum::from_values(const std::vector<double>& values) {
  if (values.size() != static_cast<std::size_t>(kGridSize)) {
    throw std::invalid_argument("a grid spectrum needs " + std::to_string(kGridSize) +
                                " values (380-780 nm at 5 nm), got " + std::to_string(values.size()));
  }
  Spectrum s;
  for (int i = 0; i < kGridSize; ++i) s[i] = values[i];
  return s;
}

}  // namespace chromo::spectral
