#pragma once
// Spectrum: 81 values on the project grid (grid.hpp). A value type; the
// arithmetic is element-wise. Units are the caller's (reflectance, relative
// power, mm^-1...): name variables after what they hold.

#include <Eigen/Core>
#include <vector>

#include "chromo/spectral/grid.hpp"

namespace chromo::spectral {

using GridArray = Eigen::Array<double, kGridSize, 1>;

class Spectrum {
 public:
  Spectrum() : values_(GridArray::Zero()) {}
  explicit Spectrum(const GridArray& values) : values_(values) {}

  static Spectrum constant(double value) { return Spectrum(GridArray::Constant(value)); }
  // From exactly kGridSize values; throws std::invalid_argument otherwise.
  static Spectrum from_values(const std::vector<double>& values);

  double operator[](int index) const { return values_[index]; }
  double& operator[](int index) { return values_[index]; }
  const GridArray& values() const { return values_; }
  GridArray& values() { return values_; }
  std::vector<double> to_vector() const { return {values_.data(), values_.data() + kGridSize}; }

  double max() const { return values_.maxCoeff(); }
  double min() const { return values_.minCoeff(); }
  // Σ value · Δλ over the grid (rectangle rule, as CIE's tabulated sums).
  double integral() const { return values_.sum() * kGridStepNm; }

  Spectrum& operator+=(const Spectrum& other) { values_ += other.values_; return *this; }
  Spectrum& operator-=(const Spectrum& other) { values_ -= other.values_; return *this; }
  Spectrum& operator*=(const Spectrum& other) { values_ *= other.values_; return *this; }
  Spectrum& operator*=(double factor) { values_ *= factor; return *this; }
  Spectrum& operator/=(double divisor) { values_ /= divisor; return *this; }

  friend Spectrum operator+(Spectrum a, const Spectrum& b) { return a += b; }
  friend Spectrum operator-(Spectrum a, const Spectrum& b) { return a -= b; }
  friend Spectrum operator*(Spectrum a, const Spectrum& b) { return a *= b; }
  friend Spectrum operator*(Spectrum a, double f) { return a *= f; }
  friend Spectrum operator*(double f, Spectrum a) { return a *= f; }
  friend Spectrum operator/(Spectrum a, double d) { return a /= d; }

 private:
  GridArray values_;
};

}  // namespace chromo::spectral
