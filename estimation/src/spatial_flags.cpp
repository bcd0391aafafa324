#include "chromo/estimation/spatial_flags.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>
#include <limits>

namespace chromo::estimation {

bool NeighbourhoodOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (!(background_sigma_px >= 1 && background_sigma_px <= 100)) return fail("background_sigma_px must be 1-100");
  if (!(deviation_sigma_px >= 0.3 && deviation_sigma_px <= 20)) return fail("deviation_sigma_px must be 0.3-20");
  if (!(background_sigma_relative >= 0)) return fail("background_sigma_relative must be >= 0");
  if (!(significance > 0 && significance < 1) || !(rim_significance > 0 && rim_significance < 1))
    return fail("significance and rim_significance must be in (0, 1)");
  if (exclusion_px < 0 || exclusion_px > 100) return fail("exclusion_px must be 0-100");
  if (!(misfit_sigma_px >= 1 && misfit_sigma_px <= 200)) return fail("misfit_sigma_px must be 1-200");
  if (!(misfit_ratio >= 1)) return fail("misfit_ratio must be >= 1");
  if (max_hole_px < 0) return fail("max_hole_px must be >= 0");
  if (max_passes < 1) return fail("max_passes must be >= 1");
  if (order_window_px < 1 || order_window_px > 63) return fail("order_window_px must be 1-63");
  return true;
}

namespace {

void check_sizes(const Estimator& estimator, std::span<const float> measured, int width, int height,
                 std::span<PixelEstimate> estimates, const NeighbourhoodOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("neighbourhood options: " + error);
  if (width < 1 || height < 1 || estimates.size() != static_cast<std::size_t>(width) * height ||
      measured.size() != estimates.size() * static_cast<std::size_t>(estimator.channels()))
    throw std::invalid_argument("spatial pass: " + std::to_string(width) + "x" + std::to_string(height) + " pixels, " +
                                std::to_string(estimates.size()) + " estimates, " + std::to_string(measured.size()) +
                                " measured values");
}

// 1D Gaussian-derived kernels u^power·g(u) for a separable normalised convolution.
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

}  // namespace

NeighbourhoodSummary refine_flags_with_neighbourhood(const Estimator& estimator, std::span<const float> measured,
                                                     int width, int height, std::span<PixelEstimate> estimates,
                                                     const NeighbourhoodOptions& options) {
  check_sizes(estimator, measured, width, height, estimates, options);
  const int channels = estimator.channels();
  const std::size_t pixels = estimates.size();
  NeighbourhoodSummary summary;
  const double deviation_threshold = chi_squared_quantile(1 - options.significance, channels);
  const double rim_threshold = chi_squared_quantile(1 - options.rim_significance, channels);
  const cv::Mat h = kernel(options.deviation_sigma_px, 0);
  cv::Mat h2;
  cv::multiply(h, h, h2);

  // Deviating pixels, kept across passes: they leave the background (so a
  // vessel or a rim does not bias the skin next to it) and are averaged only
  // with each other (so they do not bleed into that skin either).
  cv::Mat candidate(height, width, CV_8U, cv::Scalar(0));
  int settling = 0;
  for (int pass = 0; pass < options.max_passes; ++pass) {
    summary.passes = pass + 1;
    // Explained pixels and their values (zero elsewhere: flagged pixels may hold NaN).
    cv::Mat good(height, width, CV_32F, cv::Scalar(0));
    std::vector<cv::Mat> values(channels);
    for (cv::Mat& v : values) v = cv::Mat(height, width, CV_32F, cv::Scalar(0));
    for (std::size_t p = 0; p < pixels; ++p) {
      if (estimates[p].flag != PixelFlag::kExplained) continue;
      const int y = static_cast<int>(p / width), x = static_cast<int>(p % width);
      good.at<float>(y, x) = 1;
      for (int c = 0; c < channels; ++c) values[c].at<float>(y, x) = measured[p * channels + c];
    }
    cv::Mat deviating, steady;
    candidate.convertTo(deviating, CV_32F);
    deviating = deviating.mul(good);
    steady = good - deviating;
    // The background comes from skin at least exclusion_px away from flagged pixels: a flagged
    // region's weak rim must not be its own background.
    cv::Mat flagged_band, source;
    cv::dilate(good == 0, flagged_band, cv::getStructuringElement(cv::MORPH_ELLIPSE,
               cv::Size(2 * options.exclusion_px + 1, 2 * options.exclusion_px + 1)));
    steady.copyTo(source);
    source.setTo(0, flagged_band);
    const std::vector<cv::Mat> back = background(values, source, options.background_sigma_px);

    // Noise-normalised deviation, averaged over the neighbours of the same class.
    std::vector<cv::Mat> z(channels);
    for (int c = 0; c < channels; ++c) {
      z[c] = cv::Mat(height, width, CV_32F, cv::Scalar(0));
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          const float b = back[c].at<float>(y, x);
          if (!good.at<float>(y, x) || !std::isfinite(b)) continue;
          const double m = values[c].at<float>(y, x);
          const double w = estimator.weight(c, m);
          const double model = options.background_sigma_relative * m;
          const double sigma = std::sqrt(1 / (w * w) + model * model);
          z[c].at<float>(y, x) = static_cast<float>((m - b) / sigma);
        }
    }
    // Per class, the averaged deviation scaled to unit variance under camera
    // noise alone: u_c = z̄_c·√n_eff, n_eff = (Σg)²/Σg².
    std::vector<cv::Mat> u(channels);
    for (cv::Mat& m : u) m = cv::Mat(height, width, CV_32F, cv::Scalar(0));
    cv::Mat tested(height, width, CV_8U, cv::Scalar(0));
    for (const cv::Mat* cls : {&steady, &deviating}) {
      const cv::Mat sum_g = filter(*cls, h, h), sum_g2 = filter(*cls, h2, h2);
      std::vector<cv::Mat> z_mean(channels);
      for (int c = 0; c < channels; ++c) z_mean[c] = filter(z[c].mul(*cls), h, h);
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          if (!cls->at<float>(y, x) || !std::isfinite(back[0].at<float>(y, x))) continue;
          const double sg = sum_g.at<float>(y, x), sg2 = sum_g2.at<float>(y, x);
          if (!(sg > 0 && sg2 > 0)) continue;
          tested.at<std::uint8_t>(y, x) = 1;
          for (int c = 0; c < channels; ++c) u[c].at<float>(y, x) = static_cast<float>(z_mean[c].at<float>(y, x) / std::sqrt(sg2));
        }
    }
    // The skin's own scatter around its background: the local second moments
    // E[u uᵀ] of the background's source pixels (steady skin away from flagged
    // ones) over misfit_sigma_px. Camera noise alone gives the identity; where
    // the quadratic background cannot follow the skin (fields finer than its
    // window, or less noise at a longer exposure) the misfit adds to it, and
    // the statistic is measured against noise plus misfit: T = uᵀ M⁻¹ u with M
    // = E floored at the identity (eigenvalues ≥ 1).
    // The moments vary over misfit_sigma_px, so they (and M⁻¹) are computed
    // on a grid of kMisfitBlock-px blocks (area averages, filtered with the
    // kernel scaled down) and each pixel uses its block's.
    // Its source is the background's. (Tried: also excluding 6 or 12 px
    // around deviating pixels, so that an undetected rim beside them does not
    // count as misfit and hide itself: specular +28-40 points at 256 px, but
    // 6-15% of the skin flagged at 128 px, where hair strands leave little
    // skin that far from anything.)
    constexpr int kMisfitBlock = 4;
    const int block_cols = (width + kMisfitBlock - 1) / kMisfitBlock, block_rows = (height + kMisfitBlock - 1) / kMisfitBlock;
    auto to_blocks = [&](const cv::Mat& m) {
      cv::Mat padded, out;
      cv::copyMakeBorder(m, padded, 0, block_rows * kMisfitBlock - height, 0, block_cols * kMisfitBlock - width,
                         cv::BORDER_CONSTANT, 0);
      cv::resize(padded, out, cv::Size(block_cols, block_rows), 0, 0, cv::INTER_AREA);
      return out;
    };
    const cv::Mat kw = kernel(options.misfit_sigma_px / kMisfitBlock, 0);
    cv::Mat source_u;
    source.copyTo(source_u);
    source_u.setTo(0, tested == 0);
    const cv::Mat moment_mass = filter(to_blocks(source_u), kw, kw);
    std::vector<cv::Mat> moment;
    for (int c = 0; c < channels; ++c)
      for (int d = c; d < channels; ++d) moment.push_back(filter(to_blocks(u[c].mul(u[d]).mul(source_u)), kw, kw));
    const double min_mass = 0.05 * std::pow(cv::sum(kw)[0], 2);
    using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxChannels, kMaxChannels>;
    using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxChannels, 1>;
    // Per block: M⁻¹, or none (noise alone: M = I).
    std::vector<Matrix> inverse(static_cast<std::size_t>(block_cols) * block_rows);
    std::vector<char> misfit(inverse.size(), 0);
    Matrix e(channels, channels);
    Eigen::SelfAdjointEigenSolver<Matrix> eigen(channels);
    for (int by = 0; by < block_rows; ++by)
      for (int bx = 0; bx < block_cols; ++bx) {
        const double mass = moment_mass.at<float>(by, bx);
        if (!(mass > min_mass)) continue;
        double largest = 0;
        for (int c = 0, k = 0; c < channels; ++c)
          for (int d = c; d < channels; ++d, ++k) {
            e(c, d) = e(d, c) = moment[k].at<float>(by, bx) / mass;
            if (c == d) largest = std::max(largest, e(c, c));
          }
        if (largest <= options.misfit_ratio) continue;  // noise alone
        eigen.compute(e);
        const Vector lambda = eigen.eigenvalues().cwiseMax(1.0);
        const std::size_t i = static_cast<std::size_t>(by) * block_cols + bx;
        inverse[i] = eigen.eigenvectors() * lambda.cwiseInverse().asDiagonal() * eigen.eigenvectors().transpose();
        misfit[i] = 1;
      }
    cv::Mat next(height, width, CV_8U, cv::Scalar(0)), rim;
    cv::dilate(good == 0, rim, cv::Mat::ones(3, 3, CV_8U));
    Vector v(channels);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        if (!tested.at<std::uint8_t>(y, x)) continue;
        for (int c = 0; c < channels; ++c) v[c] = u[c].at<float>(y, x);
        const std::size_t block = static_cast<std::size_t>(y / kMisfitBlock) * block_cols + x / kMisfitBlock;
        const double t = misfit[block] ? v.dot(inverse[block] * v) : v.squaredNorm();
        // (Tried: beside a flagged pixel also a one-sided test of a white
        // reflection, u along a_c = 1/σ_c, one degree of freedom: specular
        // +2-5 points, but 1.2% of the skin flagged at 128 px, 2.5× exposure.)
        if (t > (rim.at<std::uint8_t>(y, x) ? rim_threshold : deviation_threshold)) next.at<std::uint8_t>(y, x) = 1;
      }
    const bool changed = cv::countNonZero(next != candidate) > 0;
    candidate = next;
    if (changed && ++settling < 6) continue;  // let the deviating set settle before deciding
    settling = 0;

    // Regions of deviating pixels that touch a flagged pixel join it.
    cv::Mat labels, stats, centroids;
    const int regions = cv::connectedComponentsWithStats(candidate, labels, stats, centroids, 8, CV_32S);
    if (regions <= 1) break;
    cv::Mat flagged_near;
    cv::Mat seeds(height, width, CV_8U, cv::Scalar(0));
    for (std::size_t p = 0; p < pixels; ++p)
      if (estimates[p].flag != PixelFlag::kExplained)
        seeds.at<std::uint8_t>(static_cast<int>(p / width), static_cast<int>(p % width)) = 1;
    cv::dilate(seeds, flagged_near, cv::Mat::ones(3, 3, CV_8U));
    std::vector<char> touches(regions, 0);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const int r = labels.at<int>(y, x);
        if (r == 0) continue;
        if (flagged_near.at<std::uint8_t>(y, x)) touches[r] = 1;
      }
    std::size_t added = 0;
    for (int r = 1; r < regions; ++r)
      if (touches[r]) added += static_cast<std::size_t>(stats.at<int>(r, cv::CC_STAT_AREA));
    if (added == 0) break;
    summary.flagged_touching += added;
    for (std::size_t p = 0; p < pixels; ++p) {
      const int y = static_cast<int>(p / width), x = static_cast<int>(p % width);
      const int r = labels.at<int>(y, x);
      if (r > 0 && touches[r]) estimates[p].flag = PixelFlag::kNeighbourhood, candidate.at<std::uint8_t>(y, x) = 0;
    }
  }
  // Holes: explained pixels enclosed by flagged ones (not reaching the image
  // border) in a region of at most max_hole_px belong to what surrounds them
  // (the middle of a highlight whose core and rim are flagged, the gap in a
  // stroke). Skin is not found inside a highlight or an ink disk.
  if (options.max_hole_px > 0) {
    cv::Mat open(height, width, CV_8U, cv::Scalar(0));
    for (std::size_t p = 0; p < pixels; ++p)
      if (estimates[p].flag == PixelFlag::kExplained) open.at<std::uint8_t>(static_cast<int>(p / width), static_cast<int>(p % width)) = 1;
    cv::Mat labels, stats, centroids;
    const int regions = cv::connectedComponentsWithStats(open, labels, stats, centroids, 4, CV_32S);
    std::vector<char> hole(regions, 0);
    for (int r = 1; r < regions; ++r) {
      const int x = stats.at<int>(r, cv::CC_STAT_LEFT), y = stats.at<int>(r, cv::CC_STAT_TOP);
      const int w = stats.at<int>(r, cv::CC_STAT_WIDTH), h = stats.at<int>(r, cv::CC_STAT_HEIGHT);
      hole[r] = x > 0 && y > 0 && x + w < width && y + h < height && stats.at<int>(r, cv::CC_STAT_AREA) <= options.max_hole_px;
    }
    for (std::size_t p = 0; p < pixels; ++p) {
      const int r = labels.at<int>(static_cast<int>(p / width), static_cast<int>(p % width));
      if (r > 0 && hole[r]) estimates[p].flag = PixelFlag::kNeighbourhood, ++summary.flagged_holes;
    }
  }
  return summary;
}

NeighbourhoodSummary pool_model_order(const Estimator& estimator, std::span<const float> measured, int width,
                                      int height, std::span<PixelEstimate> estimates,
                                      const NeighbourhoodOptions& options) {
  check_sizes(estimator, measured, width, height, estimates, options);
  NeighbourhoodSummary summary;
  if (estimator.options().model != ModelChoice::kAuto || estimator.channels() < 3) return summary;
  const int channels = estimator.channels();
  const int dof = std::min(channels, 4) - 2;
  cv::Mat tested(height, width, CV_32F, cv::Scalar(0)), statistic(height, width, CV_32F, cv::Scalar(0));
  for (std::size_t p = 0; p < estimates.size(); ++p) {
    const PixelEstimate& e = estimates[p];
    if (e.flag != PixelFlag::kExplained || (e.order != 2 && e.order != 4)) continue;
    const int y = static_cast<int>(p / width), x = static_cast<int>(p % width);
    tested.at<float>(y, x) = 1;
    statistic.at<float>(y, x) = e.order_statistic;
  }
  const cv::Size window(options.order_window_px, options.order_window_px);
  cv::Mat count, sum;
  cv::boxFilter(tested, count, CV_32F, window, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  cv::boxFilter(statistic, sum, CV_32F, window, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  const int max_count = options.order_window_px * options.order_window_px;
  std::vector<double> threshold(max_count + 1, 0);
  for (int n = 1; n <= max_count; ++n)
    threshold[n] = chi_squared_quantile(1 - estimator.options().order_significance, dof * n);
  for (std::size_t p = 0; p < estimates.size(); ++p) {
    PixelEstimate& e = estimates[p];
    const int y = static_cast<int>(p / width), x = static_cast<int>(p % width);
    if (!tested.at<float>(y, x)) continue;
    const int n = std::clamp(static_cast<int>(std::lround(count.at<float>(y, x))), 1, max_count);
    const int decided = sum.at<float>(y, x) > threshold[n] ? 4 : 2;
    if (decided == e.order) continue;
    PixelEstimate refit = estimator.estimate_pixel(measured.data() + p * channels,
                                                   decided == 4 ? ModelChoice::k4d : ModelChoice::k2d);
    if (decided == 2 && refit.flag != PixelFlag::kExplained) continue;  // the 2D model does not explain it alone
    refit.order_statistic = e.order_statistic;
    e = refit;
    ++(decided == 4 ? summary.order_to_4 : summary.order_to_2);
  }
  return summary;
}

NeighbourhoodSummary refine_with_neighbourhood(const Estimator& estimator, std::span<const float> measured, int width,
                                               int height, std::span<PixelEstimate> estimates, EstimateSummary& summary,
                                               const NeighbourhoodOptions& options) {
  NeighbourhoodSummary s;
  if (options.flags) s = refine_flags_with_neighbourhood(estimator, measured, width, height, estimates, options);
  if (options.pool_order) {
    const NeighbourhoodSummary order = pool_model_order(estimator, measured, width, height, estimates, options);
    s.order_to_2 = order.order_to_2, s.order_to_4 = order.order_to_4;
  }
  std::fill(std::begin(summary.flag_counts), std::end(summary.flag_counts), 0);
  summary.order2 = summary.order4 = 0;
  for (const PixelEstimate& e : estimates) {
    ++summary.flag_counts[static_cast<int>(e.flag)];
    summary.order2 += e.order == 2;
    summary.order4 += e.order == 4;
  }
  return s;
}

}  // namespace chromo::estimation
