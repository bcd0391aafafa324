#include "registration_signal.hpp"

#include <opencv2/imgproc.hpp>

namespace chromo::session::registration_detail {

cv::Mat less_local_mean(const cv::Mat& image, const cv::Mat& valid, double sigma_px) {
  cv::Mat weight, weighted, mean_weight, mean;
  valid.convertTo(weight, CV_32F, 1.0 / 255.0);
  cv::multiply(image, weight, weighted);
  cv::GaussianBlur(weighted, mean, cv::Size(), sigma_px, sigma_px, cv::BORDER_REFLECT);
  cv::GaussianBlur(weight, mean_weight, cv::Size(), sigma_px, sigma_px, cv::BORDER_REFLECT);
  cv::Mat out = image - mean / cv::max(mean_weight, 1e-6f);
  out.setTo(0.0f, mean_weight < 1e-3f);
  return out;
}

}  // namespace chromo::session::registration_detail
