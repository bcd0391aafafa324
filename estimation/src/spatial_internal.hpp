#pragma once
// Internal to the spatial pass (spatial_flags.cpp, model_order_pooling.cpp):
// the separable Gaussian filters and the local quadratic background of
// local_background.cpp, and the argument check both entry points share.
#include <opencv2/core.hpp>

#include <span>
#include <vector>

#include "chromo/estimation/spatial_flags.hpp"

namespace chromo::estimation::detail {

// Throws std::invalid_argument when the options are invalid or the buffers'
// sizes do not match width × height (× the estimator's channels).
void check_neighbourhood_sizes(const Estimator& estimator, std::span<const float> measured, int width, int height,
                               std::span<PixelEstimate> estimates, const NeighbourhoodOptions& options);

// 1D Gaussian-derived kernels u^power·g(u) for a separable normalised convolution.
cv::Mat kernel(double sigma, int power);
// src filtered with kx along x and ky along y (CV_32F, zero outside the image).
cv::Mat filter(const cv::Mat& src, const cv::Mat& kx, const cv::Mat& ky);
// The same filter's two passes one at a time: filter(src, kx, ky) ==
// filter_y(filter_x(src, kx), ky) bit for bit (a pass along x shared by several ky).
cv::Mat filter_x(const cv::Mat& src, const cv::Mat& kx);
cv::Mat filter_y(const cv::Mat& src, const cv::Mat& ky);
// Per channel, the local quadratic fit (normalised convolution of order 2:
// weighted least squares on 1, u, v, u², uv, v² with Gaussian weights σ) of
// the values where `good` is 1, evaluated at every pixel; NaN where the
// neighbourhood has too little support.
std::vector<cv::Mat> background(const std::vector<cv::Mat>& values, const cv::Mat& good, double sigma);

}  // namespace chromo::estimation::detail
