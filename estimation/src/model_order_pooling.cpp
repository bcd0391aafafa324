// pool_model_order (spatial_flags.hpp): the model order decided over a
// window of pixels, the part of the spatial pass that is not about flags.
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "chromo/estimation/spatial_flags.hpp"
#include "spatial_internal.hpp"

namespace chromo::estimation {

NeighbourhoodSummary pool_model_order(const Estimator& estimator, std::span<const float> measured, int width,
                                      int height, std::span<PixelEstimate> estimates,
                                      const NeighbourhoodOptions& options) {
  detail::check_neighbourhood_sizes(estimator, measured, width, height, estimates, options);
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

}  // namespace chromo::estimation
