#include "chromo/session/registration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <string>

namespace chromo::session {

namespace {

cv::Mat wrap(const std::vector<float>& v, int width, int height) {
  if (width <= 0 || height <= 0 || v.size() != static_cast<std::size_t>(width) * height)
    throw RegistrationError("registration: image of " + std::to_string(v.size()) + " values is not " +
                            std::to_string(width) + " × " + std::to_string(height));
  // Non-finite values would poison ECC's correlation: replace them by 0 in a copy.
  cv::Mat m(height, width, CV_32F);
  for (int i = 0; i < width * height; ++i) m.at<float>(i) = std::isfinite(v[i]) ? v[i] : 0.0f;
  return m;
}

RegistrationResult from_warp(const cv::Mat& w, double correlation) {
  RegistrationResult r;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) r.warp[i][j] = w.at<float>(i, j);
  r.shift_x_px = r.warp[0][2];
  r.shift_y_px = r.warp[1][2];
  r.rotation_deg = std::atan2(r.warp[1][0], r.warp[0][0]) * 180.0 / M_PI;
  r.correlation = correlation;
  return r;
}

}  // namespace

RegistrationResult estimate_registration(const std::vector<float>& reference, const std::vector<float>& moving,
                                         int width, int height, const RegistrationOptions& options) {
  const cv::Mat ref = wrap(reference, width, height), mov = wrap(moving, width, height);
  // ECC ignores moving-image pixels that are not finite (e.g. outside a warp).
  cv::Mat mask(height, width, CV_8U);
  for (int i = 0; i < width * height; ++i) mask.at<unsigned char>(i) = std::isfinite(moving[i]) ? 255 : 0;
  cv::erode(mask, mask, cv::Mat(), cv::Point(-1, -1), 3);  // image gradients near a hole are not the scene's
  // Coarse to fine: estimate on a pyramid, scaling the translation up per level.
  std::vector<cv::Mat> ref_pyramid{ref}, mov_pyramid{mov}, mask_pyramid{mask};
  for (int l = 1; l < options.pyramid_levels && std::min(ref_pyramid.back().cols, ref_pyramid.back().rows) >= 64; ++l) {
    cv::Mat r, m, k;
    cv::pyrDown(ref_pyramid.back(), r), cv::pyrDown(mov_pyramid.back(), m);
    cv::resize(mask_pyramid.back(), k, m.size(), 0, 0, cv::INTER_NEAREST);
    cv::erode(k, k, cv::Mat());  // pyrDown smears the border into the masked pixels
    ref_pyramid.push_back(r), mov_pyramid.push_back(m), mask_pyramid.push_back(k);
  }
  cv::Mat warp = cv::Mat::eye(2, 3, CV_32F);
  double correlation = 0;
  std::uint32_t skipped = 0;
  for (int level = static_cast<int>(ref_pyramid.size()) - 1; level >= 0; --level) {
    const cv::Mat before = warp.clone();
    try {
      correlation = cv::findTransformECC(ref_pyramid[level], mov_pyramid[level], warp, cv::MOTION_EUCLIDEAN,
                                         cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS,
                                                          options.max_iterations, options.epsilon),
                                         mask_pyramid[level], 5);
    } catch (const cv::Exception& e) {
      // A coarse level that does not converge (a posed view's small
      // footprint leaves little texture there) is skipped: the finer
      // levels start from the warp found so far. The finest must converge.
      if (level == 0)
        throw RegistrationError(std::string("registration (ECC) did not converge at pyramid level ") +
                                std::to_string(level) + ": " + e.what());
      warp = before;
      skipped |= 1u << level;
    }
    if (level > 0) warp.at<float>(0, 2) *= 2, warp.at<float>(1, 2) *= 2;
  }
  RegistrationResult result = from_warp(warp, correlation);
  result.skipped_levels = skipped;
  return result;
}

std::vector<float> warp_channel(const std::vector<float>& moving, int width, int height, const RegistrationResult& r) {
  if (moving.size() != static_cast<std::size_t>(width) * height)
    throw RegistrationError("warp: image size does not match " + std::to_string(width) + " × " + std::to_string(height));
  const cv::Mat src(height, width, CV_32F, const_cast<float*>(moving.data()));
  cv::Mat warp(2, 3, CV_32F);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) warp.at<float>(i, j) = static_cast<float>(r.warp[i][j]);
  cv::Mat dst;
  cv::warpAffine(src, dst, warp, src.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT,
                 cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  return {dst.ptr<float>(), dst.ptr<float>() + static_cast<std::size_t>(width) * height};
}

double corner_displacement_px(const RegistrationResult& r, int width, int height) {
  double largest = 0;
  for (double x : {0.0, width - 1.0})
    for (double y : {0.0, height - 1.0}) {
      const double dx = r.warp[0][0] * x + r.warp[0][1] * y + r.warp[0][2] - x;
      const double dy = r.warp[1][0] * x + r.warp[1][1] * y + r.warp[1][2] - y;
      largest = std::max(largest, std::hypot(dx, dy));
    }
  return largest;
}

RegistrationResult register_channel(const std::vector<float>& reference, const std::vector<float>& moving, int width,
                                    int height, const RegistrationOptions& options) {
  RegistrationResult r = estimate_registration(reference, moving, width, height, options);
  const std::vector<float> warped = warp_channel(moving, width, height, r);
  RegistrationOptions check = options;
  check.pyramid_levels = 1;
  const RegistrationResult rest = estimate_registration(reference, warped, width, height, check);
  double worst = 0;
  for (double x : {0.0, double(width - 1)})
    for (double y : {0.0, double(height - 1)}) {
      const double dx = rest.warp[0][0] * x + rest.warp[0][1] * y + rest.warp[0][2] - x;
      const double dy = rest.warp[1][0] * x + rest.warp[1][1] * y + rest.warp[1][2] - y;
      worst = std::max(worst, std::hypot(dx, dy));
    }
  r.residual_motion_px = worst;
  return r;
}

}  // namespace chromo::session
