#pragma once
// Which pixels of a capture pair follow one photometric gain and offset
// (registration.hpp: the robust round). ECC fits a single gain a and offset
// b between two captures; regions whose contrast against skin changes from
// one illuminant to another far more than skin's does (ink, marker,
// highlights) do not follow it, and across their edges the mismatch pulls
// the alignment sideways (0.355 px on a still six-LED real-skin scene,
// docs/estimation.md "Why the still scene moves"). Masking those regions,
// with a margin, leaves ECC the skin, which follows one gain closely.

#include <opencv2/core.hpp>

namespace chromo::session::registration_detail {

// Departure threshold, in robust standard deviations (1.4826 · MAD) of the
// frame's own log-ratio between the captures: a region is an outlier when its
// smoothed departure exceeds this. 4: of 3, 4 and 8 tried on one six-LED and
// one method scene (still37b, docs/estimation.md "A robust round"), the one
// that left the most still captures alone; not yet justified over seeds.
inline constexpr double kPhotometricOutlierSigmas = 4.0;
// Smoothing of both captures (Gaussian σ, px of level 0) before the
// comparison: the noise averages out, and an outlier region's departure
// spreads ~2σ beyond its edge, the margin where its edge pulls.
inline constexpr double kPhotometricSmoothingPx = 2.0;

struct PhotometricMask {
  cv::Mat consistent;        // CV_8U, 255 where the pixel follows the global gain (and `valid` said so), else 0
  double outlier_share = 0;  // share of `valid` pixels found outliers (0: `consistent` equals `valid`)
  double departure_scale = 0;  // 1.4826 · MAD of the smoothed log-ratio (infinite: not measured)
};

// reference_aligned, moving: CV_32F, same size, the reference already
// resampled onto the moving image's grid (so a still or an aligned pair).
// valid: CV_8U, non-zero where both are data. On the smoothed images, the
// departure of ln(moving / reference) from its median (the captures' one
// gain; linear albedo or radiance, so no offset) against its robust spread
// (1.4826 · MAD): outliers where it exceeds kPhotometricOutlierSigmas, the
// outliers dilated by 2σ of the smoothing. Pixels where either smoothed
// image is not positive are not judged. Statistics on every 4th pixel of
// every 4th row; fewer than 100 of them, or a MAD of 0: no outliers
// (departure_scale infinite, or 0).
PhotometricMask photometric_consistency_mask(const cv::Mat& reference_aligned, const cv::Mat& moving, const cv::Mat& valid);

}  // namespace chromo::session::registration_detail
