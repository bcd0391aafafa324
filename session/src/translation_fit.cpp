#include "translation_fit.hpp"

#include <algorithm>
#include <cstddef>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

namespace chromo::session::registration_detail {

TranslationFit translation_least_squares(const cv::Mat& ref, const cv::Mat& mov, const cv::Mat& mask, int max_iterations) {
  TranslationFit fit;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    cv::Mat shifted;
    const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, fit.tx, 0, 1, fit.ty);
    cv::warpAffine(mov, shifted, shift, mov.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
    cv::Mat gx, gy;
    cv::Sobel(shifted, gx, CV_64F, 1, 0, 1, 0.5), cv::Sobel(shifted, gy, CV_64F, 0, 1, 1, 0.5);
    Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
    Eigen::Vector4d right = Eigen::Vector4d::Zero();
    std::size_t n = 0;
    const auto each = [&](auto&& use) {
      for (int y = 1; y + 1 < ref.rows; ++y)
        for (int x = 1; x + 1 < ref.cols; ++x)
          if (mask.at<unsigned char>(y, x))
            use(Eigen::Vector4d(gx.at<double>(y, x), gy.at<double>(y, x), -ref.at<float>(y, x), -1.0),
                -static_cast<double>(shifted.at<float>(y, x)));
    };
    each([&](const Eigen::Vector4d& row, double target) { normal += row * row.transpose(), right += row * target, ++n; });
    if (n < 100) break;
    const Eigen::Vector4d step = normal.ldlt().solve(right);
    if (!step.allFinite()) break;
    double squares = 0;
    each([&](const Eigen::Vector4d& row, double target) { squares += (row.dot(step) - target) * (row.dot(step) - target); });
    const double residual_variance = squares / static_cast<double>(n - 4);
    const Eigen::Matrix4d covariance = normal.inverse() * residual_variance;
    fit.sigma_x = std::sqrt(covariance(0, 0)), fit.sigma_y = std::sqrt(covariance(1, 1));
    const double gradient_power = 0.5 * (normal(0, 0) + normal(1, 1)) / static_cast<double>(n);
    const double noise_power = std::max(residual_variance / 4, 1e-30);
    fit.gradient_snr = std::max(0.0, gradient_power - noise_power) / noise_power;
    fit.tx += step[0], fit.ty += step[1];
    fit.solved = true;
    if (std::hypot(step[0], step[1]) < 1e-4) break;
  }
  return fit;
}

}  // namespace chromo::session::registration_detail
