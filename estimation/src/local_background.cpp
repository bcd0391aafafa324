// The local quadratic background of the spatial pass (spatial_internal.hpp).
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

// Per channel, the local quadratic fit (normalised convolution of order 2:
// weighted least squares on 1, u, v, u², uv, v² with Gaussian weights) of the
// explained pixels' values around every pixel, evaluated at the pixel. A
// linear fit leaves the curvature of the skin's own variation (a few % of
// albedo over σ = 6 px) in the deviation; the quadratic one does not. NaN where
// the neighbourhood has too little support.
std::vector<cv::Mat> background(const std::vector<cv::Mat>& values, const cv::Mat& good, double sigma) {
  constexpr int kTerms = 6;
  constexpr int kPowers[kTerms][2] = {{0, 0}, {1, 0}, {0, 1}, {2, 0}, {1, 1}, {0, 2}};
  std::array<cv::Mat, 5> k;
  for (int p = 0; p < 5; ++p) k[p] = kernel(sigma, p);
  // Moments Σ g·good·u^a·v^b for a + b ≤ 4.
  std::array<std::array<cv::Mat, 5>, 5> moment;
  for (int a = 0; a <= 4; ++a)
    for (int b = 0; a + b <= 4; ++b) moment[a][b] = filter(good, k[a], k[b]);
  const double full_mass = std::pow(cv::sum(k[0])[0], 2);
  // Per pixel, the row q with background = q · (Σ g·good·m·u^a·v^b), or empty when unsupported.
  const int rows = good.rows, cols = good.cols;
  std::array<double, kTerms> ridge{};  // a little ridge on the slope and curvature terms keeps one-sided neighbourhoods stable
  for (int i = 1; i < kTerms; ++i) ridge[i] = 1e-3 * std::pow(sigma * sigma, kPowers[i][0] + kPowers[i][1]);
  std::vector<std::array<float, kTerms>> q(static_cast<std::size_t>(rows) * cols);
  std::vector<char> supported(q.size(), 0);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) {
      const double m0 = moment[0][0].at<float>(y, x);
      if (m0 < 0.15 * full_mass) continue;
      cv::Matx<double, kTerms, kTerms> a;
      for (int i = 0; i < kTerms; ++i)
        for (int j = 0; j < kTerms; ++j)
          a(i, j) = moment[kPowers[i][0] + kPowers[j][0]][kPowers[i][1] + kPowers[j][1]].at<float>(y, x);
      for (int i = 1; i < kTerms; ++i) a(i, i) += ridge[i] * m0;
      cv::Vec<double, kTerms> e0(1, 0, 0, 0, 0, 0), row;
      if (!cv::solve(a, e0, row, cv::DECOMP_CHOLESKY)) continue;
      const std::size_t i = static_cast<std::size_t>(y) * cols + x;
      for (int t = 0; t < kTerms; ++t) q[i][t] = static_cast<float>(row[t]);
      supported[i] = 1;
    }
  std::vector<cv::Mat> out;
  for (const cv::Mat& v : values) {
    const cv::Mat wv = v.mul(good);
    std::array<cv::Mat, kTerms> r;
    for (int t = 0; t < kTerms; ++t) r[t] = filter(wv, k[kPowers[t][0]], k[kPowers[t][1]]);
    cv::Mat b(v.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    for (int y = 0; y < rows; ++y)
      for (int x = 0; x < cols; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * cols + x;
        if (!supported[i]) continue;
        double sum = 0;
        for (int t = 0; t < kTerms; ++t) sum += q[i][t] * r[t].at<float>(y, x);
        b.at<float>(y, x) = static_cast<float>(sum);
      }
    out.push_back(b);
  }
  return out;
}

}  // namespace chromo::estimation::detail
