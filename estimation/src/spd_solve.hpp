#pragma once
// Internal to estimation/: the 4x4 linear solve of the inverters' bounded
// Levenberg-Marquardt / Gauss-Newton steps (inverter.cpp, fast_inverter.cpp).

#include <cmath>

namespace chromo::estimation::detail {

// Solves a·x = b for a symmetric positive semi-definite 4x4 matrix `a` (16
// values, both triangles filled, so row- and column-major read the same) by an
// unrolled Cholesky factorisation: Eigen's pivoting LDLT is a library call that
// cost as much as the table interpolation. A non-positive pivot (a singular
// direction) gives a zero step along it.
inline void solve_spd4(const double* a, const double* b, double* x) {
  double l[4][4] = {}, y[4];
  for (int j = 0; j < 4; ++j) {
    double d = a[j * 4 + j];
    for (int k = 0; k < j; ++k) d -= l[j][k] * l[j][k];
    l[j][j] = d > 1e-300 ? std::sqrt(d) : 0.0;
    for (int i = j + 1; i < 4; ++i) {
      double v = a[i * 4 + j];
      for (int k = 0; k < j; ++k) v -= l[i][k] * l[j][k];
      l[i][j] = l[j][j] > 0 ? v / l[j][j] : 0.0;
    }
  }
  for (int i = 0; i < 4; ++i) {
    double v = b[i];
    for (int k = 0; k < i; ++k) v -= l[i][k] * y[k];
    y[i] = l[i][i] > 0 ? v / l[i][i] : 0.0;
  }
  for (int i = 3; i >= 0; --i) {
    double v = y[i];
    for (int k = i + 1; k < 4; ++k) v -= l[k][i] * x[k];
    x[i] = l[i][i] > 0 ? v / l[i][i] : 0.0;
  }
}

// The bounded Gauss-Newton step of the inverters' fits (fast_inverter.cpp,
// subspace_inverter.cpp) from the normal equations jtj (16, row-major) and
// gradient Jᵀr at grid coordinates x: a coordinate at its bound (0 or
// upper) whose gradient points outward, and every coordinate from
// free_dims on, is held (its row and column cleared, its step 0). step: the
// solution of jtj·step = gradient, to be subtracted from x. Returns the
// Gauss-Newton model's predicted gain gradient·step; *held_at_bound says
// whether a free coordinate was held at a bound.
inline double bounded_gauss_newton_step(double* jtj, double* gradient, const float* x, const float* upper, int free_dims,
                                        double* step, bool* held_at_bound = nullptr) {
  bool held = false;
  for (int k = 0; k < 4; ++k) {
    const bool at_bound = (x[k] <= 0 && gradient[k] > 0) || (x[k] >= upper[k] && gradient[k] < 0);
    if (at_bound || k >= free_dims) {
      held = held || (at_bound && k < free_dims);
      for (int i = 0; i < 4; ++i) jtj[k * 4 + i] = jtj[i * 4 + k] = 0;
      jtj[k * 4 + k] = 1, gradient[k] = 0;
    } else {
      jtj[k * 4 + k] *= 1 + 1e-9;
    }
  }
  solve_spd4(jtj, gradient, step);
  if (held_at_bound) *held_at_bound = held;
  double predicted_gain = 0;
  for (int k = 0; k < 4; ++k) predicted_gain += gradient[k] * step[k];
  return predicted_gain;
}

}  // namespace chromo::estimation::detail
