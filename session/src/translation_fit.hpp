#pragma once
// A translation between two images by gradient least squares
// (registration.hpp's fallback, the block noise and the tile consensus use it).

#include <cmath>

#include <opencv2/core.hpp>

namespace chromo::session::registration_detail {

struct TranslationFit {
  double tx = 0, ty = 0;                    // px: moving(x + t) ≈ a·reference(x) + b
  double sigma_x = INFINITY, sigma_y = INFINITY;  // standard errors of t, px (pixels taken as independent)
  bool solved = false;                      // at least one step was taken
  // The mean squared gradient (per axis) of the resampled moving image over
  // the noise's share of it (the residual variance / 4: central differences
  // of two pixels' noise at half weight, the residual holding both images'
  // noise): the texture's signal-to-noise in the gradients the fit uses. The
  // estimate keeps only about snr / (1 + snr) of the motion from its start
  // where the noise is comparable to the texture (errors in the regressors).
  double gradient_snr = 0;
};

// Gauss-Newton on moving(x + t) ≈ a·reference(x) + b over the mask: t, a,
// b by linear least squares per iteration (moving resampled at x + t, its
// gradient by central differences), then the standard error of t from the
// residual. Border pixels (one each side) and masked ones are left out.
// ref, mov: CV_32F of one size; mask: CV_8U, non-zero where a pixel takes
// part. Fewer than 100 such pixels: not solved. At most max_iterations steps;
// stops when a step is below 1e-4 px.
TranslationFit translation_least_squares(const cv::Mat& ref, const cv::Mat& mov, const cv::Mat& mask, int max_iterations);

}  // namespace chromo::session::registration_detail
