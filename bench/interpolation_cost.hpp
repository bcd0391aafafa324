#pragma once
// What one forward-table interpolation costs (value only, one thread), the
// unit the fast fit's time is counted in: FastInverter::predict4 on points
// whose calls are independent (the next point does not wait for the last
// value: the core overlaps them) and dependent (each point moves by the last
// value, as in Gauss-Newton), and the same values for 8 points at once with
// AVX2 gathers (16 corners × 4 channels = 64 gathers per 8 points), the
// "SIMD across pixels" a batched fit would use. estimation_bench --diagnose
// prints it (docs/estimation-notes.md §18). False when the gathered values
// differ from predict4's (the comparison would not be of the same work).

#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "chromo/estimation/inverter.hpp"
#include "clocks.hpp"

namespace chromo::bench {

inline bool print_interpolation_costs(const estimation::FastInverter& fast) {
  const estimation::ForwardTable& table = fast.table();
  const auto n = table.nodes();
  constexpr int kPoints = 1 << 20;
  // Grid coordinates spread over the table, the same for every variant.
  constexpr int kPeriod[4] = {37, 29, 13, 7};
  std::vector<float> axis[4];
  for (int k = 0; k < 4; ++k) {
    axis[k].resize(kPoints);
    for (int i = 0; i < kPoints; ++i) axis[k][i] = std::fmod(float(i % kPeriod[k]) + 0.3f + 0.1f * k, float(n[k] - 1));
  }
  float sink = 0;
  auto ns_per_point = [](const ThreadCpuClock& clock) { return 1e9 * clock.seconds() / kPoints; };

  const ThreadCpuClock independent_clock;
  for (int i = 0; i < kPoints; ++i) {
    const float x[4] = {axis[0][i], axis[1][i], axis[2][i], axis[3][i]};
    float v[4];
    fast.predict4(x, v, nullptr);
    sink += v[0];
  }
  const double independent = ns_per_point(independent_clock);

  const ThreadCpuClock dependent_clock;
  float last[4] = {};
  for (int i = 0; i < kPoints; ++i) {
    // x waits for the last value (a zero step that the compiler cannot drop).
    const float x[4] = {axis[0][i] + last[0] * 1e-30f, axis[1][i] + last[1] * 1e-30f, axis[2][i] + last[2] * 1e-30f,
                        axis[3][i] + last[3] * 1e-30f};
    fast.predict4(x, last, nullptr);
  }
  sink += last[0];
  const double dependent = ns_per_point(dependent_clock);

#ifdef __AVX2__
  const float* values = table.values().data();
  int stride[4], corner_offset[16];
  for (int k = 0; k < 4; ++k) stride[k] = static_cast<int>(table.node_offset(k == 0, k == 1, k == 2, k == 3));
  for (int corner = 0; corner < 16; ++corner) {
    corner_offset[corner] = 0;
    for (int k = 0; k < 4; ++k)
      if (corner >> k & 1) corner_offset[corner] += stride[k];
  }
  std::vector<float> gathered(std::size_t(kPoints) * 4);
  const ThreadCpuClock gather_clock;
  const __m256 one = _mm256_set1_ps(1.0f);
  for (int i = 0; i < kPoints; i += 8) {
    __m256 weight[4][2];
    __m256i offset = _mm256_setzero_si256();
    for (int k = 0; k < 4; ++k) {
      const __m256 x = _mm256_min_ps(_mm256_max_ps(_mm256_loadu_ps(&axis[k][i]), _mm256_setzero_ps()),
                                     _mm256_set1_ps(float(n[k] - 1)));
      const __m256i base = _mm256_min_epi32(_mm256_cvttps_epi32(x), _mm256_set1_epi32(n[k] - 2));
      const __m256 f = _mm256_sub_ps(x, _mm256_cvtepi32_ps(base));
      weight[k][0] = _mm256_sub_ps(one, f), weight[k][1] = f;
      offset = _mm256_add_epi32(offset, _mm256_mullo_epi32(base, _mm256_set1_epi32(stride[k])));
    }
    __m256 v[4] = {_mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps()};
    for (int corner = 0; corner < 16; ++corner) {
      const __m256 w = _mm256_mul_ps(_mm256_mul_ps(weight[0][corner & 1], weight[1][corner >> 1 & 1]),
                                     _mm256_mul_ps(weight[2][corner >> 2 & 1], weight[3][corner >> 3 & 1]));
      const __m256i at = _mm256_add_epi32(offset, _mm256_set1_epi32(corner_offset[corner]));
      for (int c = 0; c < 4; ++c) v[c] = _mm256_fmadd_ps(w, _mm256_i32gather_ps(values + c, at, 4), v[c]);
    }
    for (int c = 0; c < 4; ++c) _mm256_storeu_ps(&gathered[std::size_t(c) * kPoints + i], v[c]);
  }
  const double gather = ns_per_point(gather_clock);
  // The same values as predict4 (a check that the comparison is fair).
  double largest_difference = 0;
  for (int i = 0; i < kPoints; i += 4099) {
    const float x[4] = {axis[0][i], axis[1][i], axis[2][i], axis[3][i]};
    float v[4];
    fast.predict4(x, v, nullptr);
    for (int c = 0; c < 4; ++c)
      largest_difference = std::max(largest_difference, double(std::abs(v[c] - gathered[std::size_t(c) * kPoints + i])));
  }
  std::printf("interpolation, value only, one thread: predict4 %.1f ns independent, %.1f ns dependent; AVX2 gathers "
              "%.1f ns per point, 8 at a time (x%.2f of predict4 independent; largest difference %.1e) (%g)\n",
              independent, dependent, gather, gather / independent, largest_difference, sink);
  return largest_difference <= 1e-5;
#else
  std::printf("interpolation, value only, one thread: predict4 %.1f ns independent, %.1f ns dependent (%g)\n",
              independent, dependent, sink);
  return true;
#endif
}

}  // namespace chromo::bench
