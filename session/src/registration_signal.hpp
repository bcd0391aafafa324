#pragma once
// The signal ECC registers on (registration.hpp, RegistrationSignal): a
// capture's channel less its local mean, so that a still scene whose regions
// change contrast from one illuminant to another gives no apparent motion.
//
// Why: between captures under different LEDs, each region of a scene (a skin
// patch, an ink disc, a marker stroke) keeps its place but changes its
// brightness by its own factor (its own spectrum), so the two captures are
// not one gain and offset apart. Across an edge between two regions the
// mismatch that one global gain leaves is a step whose mean over the edge is
// not zero, and ECC's gradient-weighted update moves the capture to reduce
// it: the apparent shift docs/estimation.md measures (0.355 px on the six
// LEDs). Less its local mean, an edge's profile is odd about the edge in both
// captures whatever its contrast, the mismatch is odd and the gradient even,
// so their product sums to zero: the edges no longer pull (only where three
// regions meet, within ~σ, does a pull remain).

#include <opencv2/core.hpp>

namespace chromo::session::registration_detail {

// image − its Gaussian-weighted local mean (σ = sigma_px), the mean over the
// pixels `valid` marks (CV_8U, non-zero: take part) only, so that holes do
// not make edges; 0 where no valid pixel is near. CV_32F in, CV_32F out.
cv::Mat less_local_mean(const cv::Mat& image, const cv::Mat& valid, double sigma_px);

}  // namespace chromo::session::registration_detail
