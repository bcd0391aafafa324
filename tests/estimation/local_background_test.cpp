// The spatial pass's local quadratic background (estimation/src/local_background.cpp):
// its shared row passes and its per-pixel solves give what the plain
// sepFilter2D per term and cv::solve per pixel give, bit for bit.
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "spatial_internal.hpp"

namespace chromo::estimation::detail {
namespace {

bool same_bits(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int y = 0; y < a.rows; ++y)
    if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
  return true;
}

// A textured field with a hole and a thin flagged border: one-sided and unsupported neighbourhoods too.
cv::Mat random_field(int rows, int cols, int seed) {
  cv::Mat m(rows, cols, CV_32F);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0.2, 0.6);
  return m;
}
cv::Mat holed_mask(int rows, int cols) {
  cv::Mat good(rows, cols, CV_32F, cv::Scalar(1));
  good(cv::Rect(cols / 3, rows / 4, cols / 3, rows / 2)).setTo(0);
  good(cv::Rect(0, 0, cols, 3)).setTo(0);
  return good;
}

// The background as it was computed before the shared passes: one
// sepFilter2D per term and cv::solve per pixel.
std::vector<cv::Mat> reference_background(const std::vector<cv::Mat>& values, const cv::Mat& good, double sigma) {
  constexpr int kTerms = 6;
  constexpr int kPowers[kTerms][2] = {{0, 0}, {1, 0}, {0, 1}, {2, 0}, {1, 1}, {0, 2}};
  std::array<cv::Mat, 5> k;
  for (int p = 0; p < 5; ++p) k[p] = kernel(sigma, p);
  std::array<std::array<cv::Mat, 5>, 5> moment;
  for (int a = 0; a <= 4; ++a)
    for (int b = 0; a + b <= 4; ++b) moment[a][b] = filter(good, k[a], k[b]);
  const double full_mass = std::pow(cv::sum(k[0])[0], 2);
  std::array<double, kTerms> ridge{};
  for (int i = 1; i < kTerms; ++i) ridge[i] = 1e-3 * std::pow(sigma * sigma, kPowers[i][0] + kPowers[i][1]);
  std::vector<cv::Mat> out;
  for (const cv::Mat& v : values) {
    const cv::Mat wv = v.mul(good);
    std::array<cv::Mat, kTerms> r;
    for (int t = 0; t < kTerms; ++t) r[t] = filter(wv, k[kPowers[t][0]], k[kPowers[t][1]]);
    cv::Mat b(v.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    for (int y = 0; y < v.rows; ++y)
      for (int x = 0; x < v.cols; ++x) {
        const double m0 = moment[0][0].at<float>(y, x);
        if (m0 < 0.15 * full_mass) continue;
        cv::Matx<double, kTerms, kTerms> a;
        for (int i = 0; i < kTerms; ++i)
          for (int j = 0; j < kTerms; ++j)
            a(i, j) = moment[kPowers[i][0] + kPowers[j][0]][kPowers[i][1] + kPowers[j][1]].at<float>(y, x);
        for (int i = 1; i < kTerms; ++i) a(i, i) += ridge[i] * m0;
        cv::Vec<double, kTerms> e0(1, 0, 0, 0, 0, 0), row;
        if (!cv::solve(a, e0, row, cv::DECOMP_CHOLESKY)) continue;
        double sum = 0;
        for (int t = 0; t < kTerms; ++t) sum += static_cast<float>(row[t]) * r[t].at<float>(y, x);
        b.at<float>(y, x) = static_cast<float>(sum);
      }
    out.push_back(b);
  }
  return out;
}

TEST(LocalBackground, SharedRowPassesEqualSepFilter2DBitForBit) {
  const cv::Mat src = random_field(61, 83, 1).mul(holed_mask(61, 83));
  for (int a = 0; a <= 4; ++a)
    for (int b = 0; a + b <= 4; ++b)
      EXPECT_TRUE(same_bits(filter_y(filter_x(src, kernel(6, a)), kernel(6, b)), filter(src, kernel(6, a), kernel(6, b))))
          << "row power " << a << ", column power " << b;
}

TEST(LocalBackground, EqualsOneFilterPerTermAndCvSolvePerPixelBitForBit) {
  const int rows = 71, cols = 89;
  const cv::Mat good = holed_mask(rows, cols);
  const std::vector<cv::Mat> values = {random_field(rows, cols, 2), random_field(rows, cols, 3)};
  const std::vector<cv::Mat> got = background(values, good, 6), want = reference_background(values, good, 6);
  ASSERT_EQ(got.size(), want.size());
  int unsupported = 0;
  for (std::size_t c = 0; c < got.size(); ++c) {
    EXPECT_TRUE(same_bits(got[c], want[c])) << "channel " << c;
    unsupported += rows * cols - cv::countNonZero(want[c] == want[c]);
  }
  EXPECT_GT(unsupported, 0);  // the hole's middle has no support: NaN in both
}

}  // namespace
}  // namespace chromo::estimation::detail
