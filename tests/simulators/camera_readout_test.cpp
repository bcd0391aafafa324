// The camera model's readout (CameraModel::expose) at the statistics it
// states: mean and variance per signal level (against the stated figures and
// against the single-stream readout it replaced), the normal variates' tails,
// exact Poisson at small means, and frames independent of the thread count.
// Every tolerance is a number of standard errors of the sample at hand.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/simulators/camera/readout_random.hpp"

namespace chromo::simulators {
namespace {

constexpr double kStandardErrors = 5;  // tolerance of every statistical assertion below

// P(N(0, 1) > z).
double upper_tail(double z) { return 0.5 * std::erfc(z / std::sqrt(2.0)); }

// The chi-square value exceeded with probability ~3e-7 (z = 5) for `dof`
// degrees of freedom (Wilson & Hilferty's cube-root approximation).
double chi_square_bound(int dof) {
  const double a = 2.0 / (9.0 * dof);
  return dof * std::pow(1 - a + kStandardErrors * std::sqrt(a), 3);
}

struct SampleMoments {
  double n = 0, mean = 0, variance = 0;
  double mean_error = 0, variance_error = 0;  // standard errors of the two estimates
};

// Mean and variance of every sample of a CV_16U frame, with their standard
// errors (the variance's from the sample's fourth central moment).
SampleMoments moments_of(const cv::Mat& dn) {
  SampleMoments m;
  m.n = static_cast<double>(dn.total());
  double sum = 0;
  for (int y = 0; y < dn.rows; ++y)
    for (int x = 0; x < dn.cols; ++x) sum += dn.at<std::uint16_t>(y, x);
  m.mean = sum / m.n;
  double m2 = 0, m4 = 0;
  for (int y = 0; y < dn.rows; ++y)
    for (int x = 0; x < dn.cols; ++x) {
      const double d = dn.at<std::uint16_t>(y, x) - m.mean;
      m2 += d * d, m4 += d * d * d * d;
    }
  m.variance = m2 / (m.n - 1);
  m4 /= m.n;
  m.mean_error = std::sqrt(m.variance / m.n);
  m.variance_error = std::sqrt(std::max(m4 - m.variance * m.variance * (m.n - 3) / (m.n - 1), 0.0) / m.n);
  return m;
}

// A uniform mono response giving `electrons` at `exposure_us`.
cv::Mat response_for(const CameraModel& model, double electrons, double exposure_us, int size) {
  const double response = electrons / (model.options().quantum_scale_e_per_us * exposure_us);
  return cv::Mat(size, size, CV_32FC3, cv::Scalar::all(response));
}

TEST(CameraReadout, MeanAndVariancePerLevelAreTheStatedOnesAndTheSingleStreamReadouts) {
  const CameraModel model{CameraModelOptions{}};
  constexpr double kExposureUs = 10000;
  constexpr int kSize = 512;  // 262,144 samples per level and readout
  // Dark, exact Poisson (below 30 e⁻), its normal approximation, mid-scale;
  // then near and beyond the full well (20,000 e⁻), whose clamp the stated
  // sigma ignores: compared with the single-stream readout only.
  const std::vector<double> levels_e = {0, 3, 12, 29, 31, 300, 5000, 15000, 19900, 30000};
  std::uint64_t frame = 0;
  for (const double electrons : levels_e) {
    SCOPED_TRACE(testing::Message() << electrons << " electrons");
    const cv::Mat response = response_for(model, electrons, kExposureUs, kSize);
    const double level = response.at<cv::Vec3f>(0, 0)[0];
    const SampleMoments fast = moments_of(model.expose(response, SensorLayout::kMono, 0, 0, kExposureUs, 0, frame));
    const SampleMoments single =
        moments_of(model.expose_single_stream(response, SensorLayout::kMono, 0, 0, kExposureUs, 0, frame));
    ++frame;
    const double mean_tolerance = kStandardErrors * std::hypot(fast.mean_error, single.mean_error);
    const double variance_tolerance = kStandardErrors * std::hypot(fast.variance_error, single.variance_error);
    EXPECT_NEAR(fast.mean, single.mean, mean_tolerance);
    EXPECT_NEAR(fast.variance, single.variance, variance_tolerance);
    if (electrons < 19000) {
      const double sigma = model.noise_sigma_dn(level, kExposureUs, 0);
      EXPECT_NEAR(fast.mean, model.expected_dn(level, kExposureUs, 0), kStandardErrors * fast.mean_error);
      EXPECT_NEAR(fast.variance, sigma * sigma, kStandardErrors * fast.variance_error);
    }
    if (electrons >= 30000) {
      EXPECT_EQ(fast.variance, 0.0);  // saturated: full scale, no noise
    }
  }
}

// The ziggurat's variates against N(0, 1): moments, the body's shape
// (34 bins) and the tails beyond 3, 4 and 5σ.
TEST(CameraReadout, ZigguratVariatesAreStandardNormalIntoTheTails) {
  readout_random::Xoshiro256Plus rng(12345);
  const readout_random::ZigguratNormal normal;
  constexpr int kDraws = 10'000'000;
  constexpr double kBinWidth = 0.25, kBodyEdge = 4.0;
  constexpr int kBodyBins = static_cast<int>(2 * kBodyEdge / kBinWidth);
  std::vector<double> bins(kBodyBins + 2, 0.0);  // [−∞, −4), 32 bins of 0.25, [4, ∞)
  double sum = 0, sum2 = 0, beyond[3] = {0, 0, 0};
  for (int i = 0; i < kDraws; ++i) {
    const double z = normal(rng);
    sum += z, sum2 += z * z;
    for (int k = 0; k < 3; ++k) beyond[k] += std::abs(z) > 3 + k;
    const int bin = z < -kBodyEdge  ? 0
                    : z >= kBodyEdge ? kBodyBins + 1
                                     : 1 + std::min(static_cast<int>((z + kBodyEdge) / kBinWidth), kBodyBins - 1);
    bins[bin] += 1;
  }
  EXPECT_NEAR(sum / kDraws, 0.0, kStandardErrors / std::sqrt(kDraws));
  EXPECT_NEAR(sum2 / kDraws, 1.0, kStandardErrors * std::sqrt(2.0 / kDraws));
  for (int k = 0; k < 3; ++k) {
    const double p = 2 * upper_tail(3 + k), expected = p * kDraws;
    EXPECT_NEAR(beyond[k], expected, kStandardErrors * std::sqrt(expected * (1 - p))) << "beyond " << 3 + k << " sigma";
    std::printf("beyond %d sigma: %.0f (expected %.1f)\n", 3 + k, beyond[k], expected);
  }
  double chi_square = 0;
  for (int b = 0; b < kBodyBins + 2; ++b) {
    const double lo = b == 0 ? -INFINITY : -kBodyEdge + (b - 1) * kBinWidth;
    const double hi = b == kBodyBins + 1 ? INFINITY : -kBodyEdge + b * kBinWidth;
    const double expected = kDraws * (upper_tail(lo) - upper_tail(hi));
    chi_square += (bins[b] - expected) * (bins[b] - expected) / expected;
  }
  EXPECT_LT(chi_square, chi_square_bound(kBodyBins + 1));
}

// Beyond 3σ and 4σ in a frame at 10,000 e⁻ (shot noise by the normal
// approximation plus read noise), counted against the rounded normal's own
// probabilities: 16-bit ADC at 1 e⁻/DN, so nothing clips.
TEST(CameraReadout, FrameTailsAreTheRoundedNormals) {
  CameraModelOptions options;
  options.adc_bits = 16;
  options.gain_e_per_dn = 1;
  options.full_well_e = 60000;
  options.black_level_dn = 1000;
  const CameraModel model{options};
  constexpr double kExposureUs = 5000;
  const cv::Mat response = response_for(model, 10000, kExposureUs, 1024);
  const double electrons = kExposureUs * options.quantum_scale_e_per_us * response.at<cv::Vec3f>(0, 0)[0];
  const double mean_dn = options.black_level_dn + electrons;
  const double sigma_dn = std::sqrt(electrons + options.read_noise_e * options.read_noise_e);
  const cv::Mat dn = model.expose(response, SensorLayout::kMono, 0, 0, kExposureUs, 0, 42);
  for (const double k : {3.0, 4.0}) {
    double counted = 0, p = 0;
    for (int y = 0; y < dn.rows; ++y)
      for (int x = 0; x < dn.cols; ++x) counted += std::abs(dn.at<std::uint16_t>(y, x) - mean_dn) > k * sigma_dn;
    // P(|round(X) − μ| > kσ), X ~ N(μ, σ): the integers n beyond, each P(n − ½ ≤ X < n + ½).
    for (double n = std::floor(mean_dn - 8 * sigma_dn); n <= mean_dn + 8 * sigma_dn; n += 1)
      if (std::abs(n - mean_dn) > k * sigma_dn)
        p += upper_tail((n - 0.5 - mean_dn) / sigma_dn) - upper_tail((n + 0.5 - mean_dn) / sigma_dn);
    const double expected = p * static_cast<double>(dn.total());
    EXPECT_NEAR(counted, expected, kStandardErrors * std::sqrt(expected * (1 - p))) << "beyond " << k << " sigma";
    std::printf("frame beyond %.0f sigma: %.0f (expected %.1f)\n", k, counted, expected);
  }
}

// Below 30 e⁻ (dark captures, the shadows) the shot noise is an exact
// Poisson variate: read noise 0 and 1 e⁻/DN make DN − black the count itself.
TEST(CameraReadout, SmallMeansArePoissonCounts) {
  CameraModelOptions options;
  options.read_noise_e = 0;
  options.gain_e_per_dn = 1;
  const CameraModel model{options};
  constexpr double kExposureUs = 1000;
  constexpr int kSize = 512;
  std::uint64_t frame = 100;
  for (const double level_e : {0.0, 0.5, 3.0, 12.0, 29.5}) {
    SCOPED_TRACE(testing::Message() << level_e << " electrons");
    const cv::Mat response = response_for(model, level_e, kExposureUs, kSize);
    const double mean = kExposureUs * options.quantum_scale_e_per_us * response.at<cv::Vec3f>(0, 0)[0];
    const cv::Mat dn = model.expose(response, SensorLayout::kMono, 0, 0, kExposureUs, 0, frame++);
    std::vector<double> counts(200, 0.0);
    for (int y = 0; y < dn.rows; ++y)
      for (int x = 0; x < dn.cols; ++x) {
        const int k = dn.at<std::uint16_t>(y, x) - static_cast<int>(options.black_level_dn);
        ASSERT_GE(k, 0);
        counts[std::min(k, 199)] += 1;
      }
    const double n = static_cast<double>(dn.total());
    if (level_e == 0) {
      EXPECT_EQ(counts[0], n);  // no light, no read noise: the black level exactly
      continue;
    }
    // Chi-square over the counts whose expected number is ≥ 20, the rest pooled into the two ends.
    double chi_square = 0, pooled_observed = 0, pooled_expected = 0, pmf = std::exp(-mean);
    int bins = 0;
    for (int k = 0; k < 199; ++k, pmf *= mean / k) {
      if (n * pmf >= 20) {
        chi_square += (counts[k] - n * pmf) * (counts[k] - n * pmf) / (n * pmf);
        ++bins;
      } else {
        pooled_observed += counts[k], pooled_expected += n * pmf;
      }
    }
    pooled_observed += counts[199];
    chi_square += (pooled_observed - pooled_expected) * (pooled_observed - pooled_expected) / pooled_expected;
    EXPECT_LT(chi_square, chi_square_bound(bins)) << bins + 1 << " bins";
  }
}

TEST(CameraReadout, FramesAreTheSameForAnyThreadCountAndSeededByCameraAndFrame) {
  // 203 rows: six whole bands of 32 rows and a short one; Bayer with an odd phase.
  const cv::Mat response(203, 157, CV_32FC3, cv::Scalar(0.05, 0.2, 0.00002));
  auto frame = [&](int threads, std::uint64_t seed, std::uint64_t index) {
    CameraModelOptions options;
    options.readout_threads = threads;
    options.seed = seed;
    return CameraModel(options).expose(response, SensorLayout::kBayerRGGB, 1, 3, 8000, 0, index);
  };
  const cv::Mat one_thread = frame(1, 7, 3);
  for (const int threads : {0, 2, 3, 8}) EXPECT_EQ(cv::norm(one_thread, frame(threads, 7, 3), cv::NORM_L1), 0.0) << threads;
  EXPECT_GT(cv::norm(one_thread, frame(1, 7, 4), cv::NORM_L1), 0.0);  // another frame
  EXPECT_GT(cv::norm(one_thread, frame(1, 8, 3), cv::NORM_L1), 0.0);  // another camera
  // A band's noise is its own: the first 64 rows read alone are the frame's first 64 rows.
  CameraModelOptions options;
  options.seed = 7;
  const cv::Mat top = CameraModel(options).expose(response.rowRange(0, 64), SensorLayout::kBayerRGGB, 1, 3, 8000, 0, 3);
  EXPECT_EQ(cv::norm(top, one_thread.rowRange(0, 64), cv::NORM_L1), 0.0);
  // Bands differ from one another (their streams are not copies).
  EXPECT_GT(cv::norm(one_thread.rowRange(0, 32), one_thread.rowRange(32, 64), cv::NORM_L1), 0.0);
  options.readout_threads = -1;
  EXPECT_THROW(CameraModel{options}, std::invalid_argument);
}

}  // namespace
}  // namespace chromo::simulators
