#include "photometric_mask.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace chromo::session::registration_detail {

namespace {

// The image's Gaussian mean over the valid pixels only (holes make no edges).
cv::Mat smoothed(const cv::Mat& image, const cv::Mat& weight, const cv::Mat& weight_mean) {
  cv::Mat weighted, mean;
  cv::multiply(image, weight, weighted);
  cv::GaussianBlur(weighted, mean, cv::Size(), kPhotometricSmoothingPx, kPhotometricSmoothingPx, cv::BORDER_REFLECT);
  return mean / cv::max(weight_mean, 1e-6f);
}

double median_of(std::vector<double> values) {
  auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace

PhotometricMask photometric_consistency_mask(const cv::Mat& reference_aligned, const cv::Mat& moving, const cv::Mat& valid) {
  PhotometricMask out{valid.clone(), 0, std::numeric_limits<double>::infinity()};
  cv::Mat weight, weight_mean;
  valid.convertTo(weight, CV_32F, 1.0 / 255.0);
  cv::GaussianBlur(weight, weight_mean, cv::Size(), kPhotometricSmoothingPx, kPhotometricSmoothingPx, cv::BORDER_REFLECT);
  const cv::Mat ref = smoothed(reference_aligned, weight, weight_mean), mov = smoothed(moving, weight, weight_mean);
  // ln(moving / reference) where both are light (a ratio is not defined elsewhere: those pixels are not judged).
  const cv::Mat judged = (ref > 0) & (mov > 0) & (valid != 0);
  cv::Mat log_ref, log_mov, log_ratio;
  cv::log(cv::max(ref, 1e-30f), log_ref), cv::log(cv::max(mov, 1e-30f), log_mov);
  log_ratio = log_mov - log_ref;
  std::vector<double> samples;
  for (int y = 0; y < valid.rows; y += 4)
    for (int x = 0; x < valid.cols; x += 4)
      if (judged.at<unsigned char>(y, x) && weight_mean.at<float>(y, x) > 0.99f) samples.push_back(log_ratio.at<float>(y, x));
  if (samples.size() < 100) return out;
  const double centre = median_of(samples);
  for (double& d : samples) d = std::abs(d - centre);
  const double scale = 1.4826 * median_of(std::move(samples));
  if (!(scale > 0) || !std::isfinite(scale)) return out;
  out.departure_scale = scale;
  cv::Mat outliers = (cv::abs(log_ratio - centre) > kPhotometricOutlierSigmas * scale) & judged;
  const int total = cv::countNonZero(valid);
  if (cv::countNonZero(outliers) == 0 || total == 0) return out;
  const int margin = static_cast<int>(std::ceil(2 * kPhotometricSmoothingPx));
  cv::dilate(outliers, outliers, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * margin + 1, 2 * margin + 1)));
  out.consistent.setTo(0, outliers);
  out.outlier_share = static_cast<double>(total - cv::countNonZero(out.consistent)) / total;
  return out;
}

}  // namespace chromo::session::registration_detail
