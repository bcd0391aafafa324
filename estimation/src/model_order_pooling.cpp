// pool_model_order (spatial_flags.hpp): the model order decided over a
// window of pixels, the part of the spatial pass that is not about flags.
#include <omp.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "chromo/estimation/spatial_flags.hpp"
#include "spatial_internal.hpp"

namespace chromo::estimation {

NeighbourhoodSummary pool_model_order(const Estimator& estimator, std::span<const float> measured, int width,
                                      int height, std::span<PixelEstimate> estimates,
                                      const NeighbourhoodOptions& options, std::span<const OtherOrderFit> other) {
  detail::check_neighbourhood_sizes(estimator, measured, width, height, estimates, options);
  if (!other.empty() && other.size() != estimates.size())
    throw std::invalid_argument("pool_model_order: " + std::to_string(other.size()) + " other-order fits for " +
                                std::to_string(estimates.size()) + " estimates");
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
  // Which pixels the window moves to the other order (cheap, in order), then
  // their refits on the estimator's threads: each refit reads only its own
  // pixel's measurement and writes only its own estimate, so the maps are
  // the same bit for bit on any number of threads.
  std::vector<std::size_t> moved;
  for (std::size_t p = 0; p < estimates.size(); ++p) {
    const int y = static_cast<int>(p / width), x = static_cast<int>(p % width);
    if (!tested.at<float>(y, x)) continue;
    const int n = std::clamp(static_cast<int>(std::lround(count.at<float>(y, x))), 1, max_count);
    const int decided = sum.at<float>(y, x) > threshold[n] ? 4 : 2;
    if (decided != estimates[p].order) moved.push_back(p);
  }
  const std::ptrdiff_t refits = static_cast<std::ptrdiff_t>(moved.size());
  const int threads = estimator.options().threads > 0 ? estimator.options().threads : omp_get_num_procs();
  std::size_t to_4 = 0, to_2 = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256) reduction(+ : to_4, to_2) if (refits > 256)
  for (std::ptrdiff_t i = 0; i < refits; ++i) {
    PixelEstimate& e = estimates[moved[i]];
    const bool to_order_4 = e.order == 2;  // moved: the window decided the other order
    const float* m = measured.data() + moved[i] * channels;
    // The first pass's fit of that order where it kept one (the same fit a
    // refit would make), else a refit.
    const OtherOrderFit* stored =
        !other.empty() && other[moved[i]].order == (to_order_4 ? 4 : 2) ? &other[moved[i]] : nullptr;
    // A 2D fit above the 2D threshold leaves the pixel unexplained: it stays 4.
    if (stored && !to_order_4 && !(stored->chi2 <= estimator.flag_threshold(2))) continue;
    PixelEstimate refit = stored ? estimator.estimate_from_fit(m, *stored)
                                 : estimator.estimate_pixel(m, to_order_4 ? ModelChoice::k4d : ModelChoice::k2d);
    if (!to_order_4 && refit.flag != PixelFlag::kExplained) continue;  // the 2D model does not explain it alone
    refit.order_statistic = e.order_statistic;
    e = refit;
    ++(to_order_4 ? to_4 : to_2);
  }
  summary.order_to_4 = to_4, summary.order_to_2 = to_2;
  return summary;
}

}  // namespace chromo::estimation
