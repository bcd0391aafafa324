// The local quadratic background of the spatial pass (spatial_internal.hpp).
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>

#include <array>
#include <cmath>
#include <limits>

#include "spatial_internal.hpp"

namespace chromo::estimation::detail {

cv::Mat kernel(double sigma, int power) {
  const int radius = static_cast<int>(std::ceil(3 * sigma));
  cv::Mat k(2 * radius + 1, 1, CV_32F);
  for (int u = -radius; u <= radius; ++u)
    k.at<float>(u + radius) = static_cast<float>(std::pow(u, power) * std::exp(-0.5 * u * u / (sigma * sigma)));
  return k;
}

cv::Mat filter(const cv::Mat& src, const cv::Mat& kx, const cv::Mat& ky) {
  cv::Mat dst;
  cv::sepFilter2D(src, dst, CV_32F, kx, ky, cv::Point(-1, -1), 0, cv::BORDER_CONSTANT);
  return dst;
}

// src filtered along x only, then along y only, by the same passes
// sepFilter2D makes (its row filter into a float buffer, then its column
// filter; a 1-tap kernel of 1 is exact): filter(src, kx, ky) ==
// filter_y(filter_x(src, kx), ky) bit for bit (test
// NeighbourhoodFlags.SharedRowPassesEqualSepFilter2DBitForBit), so the
// terms sharing a row kernel share its pass.
cv::Mat filter_x(const cv::Mat& src, const cv::Mat& kx) { return filter(src, kx, cv::Mat::ones(1, 1, CV_32F)); }
cv::Mat filter_y(const cv::Mat& src, const cv::Mat& ky) { return filter(src, cv::Mat::ones(1, 1, CV_32F), ky); }

namespace {

constexpr int kTerms = 6;
constexpr int kPowers[kTerms][2] = {{0, 0}, {1, 0}, {0, 1}, {2, 0}, {1, 1}, {0, 2}};

// The per-pixel rows q (background = q · (Σ g·good·m·u^a·v^b)) from the
// moment maps; supported[i] = 0 where the neighbourhood is too thin or the
// system not positive definite. Each pixel's 6×6 system goes straight to
// OpenCV's Cholesky (what cv::solve(…, DECOMP_CHOLESKY) calls after copying
// into heap buffers: the same arithmetic, no allocation per pixel); rows of
// pixels in parallel on OpenCV's pool, each pixel written by one task.
void background_rows(const std::array<std::array<cv::Mat, 5>, 5>& moment, double full_mass, double sigma,
                     std::vector<std::array<float, kTerms>>& q, std::vector<char>& supported) {
  const int rows = moment[0][0].rows, cols = moment[0][0].cols;
  std::array<double, kTerms> ridge{};  // a little ridge on the slope and curvature terms keeps one-sided neighbourhoods stable
  for (int i = 1; i < kTerms; ++i) ridge[i] = 1e-3 * std::pow(sigma * sigma, kPowers[i][0] + kPowers[i][1]);
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
    std::array<std::array<const float*, 5>, 5> row{};
    for (int y = range.start; y < range.end; ++y) {
      for (int a = 0; a <= 4; ++a)
        for (int b = 0; a + b <= 4; ++b) row[a][b] = moment[a][b].ptr<float>(y);
      for (int x = 0; x < cols; ++x) {
        const double m0 = row[0][0][x];
        if (m0 < 0.15 * full_mass) continue;
        double a[kTerms * kTerms], e[kTerms] = {1, 0, 0, 0, 0, 0};
        for (int i = 0; i < kTerms; ++i)
          for (int j = 0; j < kTerms; ++j)
            a[i * kTerms + j] = row[kPowers[i][0] + kPowers[j][0]][kPowers[i][1] + kPowers[j][1]][x];
        for (int i = 1; i < kTerms; ++i) a[i * kTerms + i] += ridge[i] * m0;
        if (!cv::hal::Cholesky64f(a, kTerms * sizeof(double), kTerms, e, sizeof(double), 1)) continue;
        const std::size_t i = static_cast<std::size_t>(y) * cols + x;
        for (int t = 0; t < kTerms; ++t) q[i][t] = static_cast<float>(e[t]);
        supported[i] = 1;
      }
    }
  });
}

}  // namespace

// Per channel, the local quadratic fit (normalised convolution of order 2:
// weighted least squares on 1, u, v, u², uv, v² with Gaussian weights) of the
// explained pixels' values around every pixel, evaluated at the pixel. A
// linear fit leaves the curvature of the skin's own variation (a few % of
// albedo over σ = 6 px) in the deviation; the quadratic one does not. NaN where
// the neighbourhood has too little support.
std::vector<cv::Mat> background(const std::vector<cv::Mat>& values, const cv::Mat& good, double sigma) {
  std::array<cv::Mat, 5> k;
  for (int p = 0; p < 5; ++p) k[p] = kernel(sigma, p);
  // Moments Σ g·good·u^a·v^b for a + b ≤ 4: one pass along x per a, then along y per b.
  std::array<std::array<cv::Mat, 5>, 5> moment;
  for (int a = 0; a <= 4; ++a) {
    const cv::Mat along_x = filter_x(good, k[a]);
    for (int b = 0; a + b <= 4; ++b) moment[a][b] = filter_y(along_x, k[b]);
  }
  const double full_mass = std::pow(cv::sum(k[0])[0], 2);
  const int rows = good.rows, cols = good.cols;
  std::vector<std::array<float, kTerms>> q(static_cast<std::size_t>(rows) * cols);
  std::vector<char> supported(q.size(), 0);
  background_rows(moment, full_mass, sigma, q, supported);
  std::vector<cv::Mat> out;
  for (const cv::Mat& v : values) {
    const cv::Mat wv = v.mul(good);
    std::array<cv::Mat, kTerms> r;
    for (int a = 0; a <= 2; ++a) {
      const cv::Mat along_x = filter_x(wv, k[a]);
      for (int t = 0; t < kTerms; ++t)
        if (kPowers[t][0] == a) r[t] = filter_y(along_x, k[kPowers[t][1]]);
    }
    cv::Mat b(v.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
      for (int y = range.start; y < range.end; ++y) {
        float* out_row = b.ptr<float>(y);
        std::array<const float*, kTerms> r_row;
        for (int t = 0; t < kTerms; ++t) r_row[t] = r[t].ptr<float>(y);
        for (int x = 0; x < cols; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * cols + x;
          if (!supported[i]) continue;
          double sum = 0;
          for (int t = 0; t < kTerms; ++t) sum += q[i][t] * r_row[t][x];
          out_row[x] = static_cast<float>(sum);
        }
      }
    });
    out.push_back(b);
  }
  return out;
}

}  // namespace chromo::estimation::detail
