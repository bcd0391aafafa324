#include "chromo/session/registration.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>
#include <cmath>
#include <limits>
#include <optional>
#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <string>

#include "photometric_mask.hpp"
#include "tile_motion.hpp"
#include "translation_fit.hpp"
#include "registration_signal.hpp"

namespace chromo::session {

namespace {

using registration_detail::TranslationFit;
using registration_detail::translation_least_squares;

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

constexpr double kMinimumOverlap = 0.5;
constexpr double kMaximumRotationDeg = 10;

// Share of the reference's pixels that the warp maps inside the moving image.
double overlap_fraction(const RegistrationResult& r, int width, int height) {
  std::size_t inside = 0, total = 0;
  for (int y = 0; y < height; y += 4)
    for (int x = 0; x < width; x += 4, ++total) {
      const double mx = r.warp[0][0] * x + r.warp[0][1] * y + r.warp[0][2];
      const double my = r.warp[1][0] * x + r.warp[1][1] * y + r.warp[1][2];
      inside += mx >= 0 && mx <= width - 1 && my >= 0 && my <= height - 1;
    }
  return total ? static_cast<double>(inside) / static_cast<double>(total) : 0.0;
}

RegistrationResult translation_fallback(const cv::Mat& ref, const cv::Mat& mov, const cv::Mat& mask,
                                        const std::string& ecc_error) {
  const TranslationFit fit = translation_least_squares(ref, mov, mask, 20);
  const double tx = fit.tx, ty = fit.ty;
  const double sigma = std::max(fit.sigma_x, fit.sigma_y);
  if (!(3 * sigma <= kTranslationFallbackUncertaintyPx) || !std::isfinite(tx) || !std::isfinite(ty))
    throw RegistrationError(ecc_error + "; the translation fallback measures the motion only to ±" +
                            std::to_string(3 * sigma) + " px (3σ), more than " +
                            std::to_string(kTranslationFallbackUncertaintyPx) + " px: the captures are too featureless");
  RegistrationResult r;
  r.warp[0][2] = r.shift_x_px = tx;
  r.warp[1][2] = r.shift_y_px = ty;
  r.method = RegistrationMethod::kTranslation;
  r.translation_sigma_px = sigma;
  return r;
}

// The registration's own noise (RegistrationResult::motion_noise_px): the
// warped moving image against the reference in a kNoiseBlocks × kNoiseBlocks
// grid, each block's remaining translation by the least squares above; the
// standard error of their mean from their spread, √(Σ|t_b − t̄|² / (B(B − 1))).
// Unlike the residual's σ (pixels taken as independent), the spread between
// blocks holds what differs between the captures region by region (patterns
// whose contrast changes with the illuminant pull each block its own way),
// which is what a still scene's apparent motion is made of. Large frames are
// measured on a pyramid level of at most ~1 MP (the spread scaled back up).
constexpr int kNoiseBlocks = 4;
double motion_noise_px(const cv::Mat& ref_full, const cv::Mat& warped_full, const cv::Mat& mask_full) {
  cv::Mat ref = ref_full, warped = warped_full, mask = mask_full;
  double scale = 1;
  while (static_cast<double>(ref.rows) * ref.cols > 1.2e6) {
    cv::Mat r, m, k;
    cv::pyrDown(ref, r), cv::pyrDown(warped, m);
    cv::resize(mask, k, m.size(), 0, 0, cv::INTER_NEAREST);
    cv::erode(k, k, cv::Mat());
    ref = r, warped = m, mask = k, scale *= 2;
  }
  std::vector<Eigen::Vector2d> shifts;
  for (int by = 0; by < kNoiseBlocks; ++by)
    for (int bx = 0; bx < kNoiseBlocks; ++bx) {
      const cv::Rect block(bx * ref.cols / kNoiseBlocks, by * ref.rows / kNoiseBlocks, ref.cols / kNoiseBlocks,
                           ref.rows / kNoiseBlocks);
      if (block.width < 8 || block.height < 8) continue;
      const TranslationFit fit = translation_least_squares(ref(block), warped(block), mask(block), 3);
      // A featureless block (background, a smooth view) measures nothing; it does not vote.
      const bool measured = fit.solved && 3 * std::max(fit.sigma_x, fit.sigma_y) <= kTranslationFallbackUncertaintyPx;
      if (measured && std::isfinite(fit.tx) && std::isfinite(fit.ty)) shifts.emplace_back(fit.tx, fit.ty);
    }
  const double blocks = static_cast<double>(shifts.size());
  if (blocks < 4) return std::numeric_limits<double>::infinity();
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& t : shifts) mean += t / blocks;
  double squares = 0;
  for (const auto& t : shifts) squares += (t - mean).squaredNorm();
  return scale * std::sqrt(squares / (blocks * (blocks - 1)));
}

// Pixels of an image that are finite (255) or not (0).
cv::Mat finite_mask(const std::vector<float>& image, int width, int height) {
  cv::Mat mask(height, width, CV_8U);
  for (int i = 0; i < width * height; ++i) mask.at<unsigned char>(i) = std::isfinite(image[i]) ? 255 : 0;
  return mask;
}

// Pixels of the moving image that take part: finite ones, away from holes.
cv::Mat moving_mask(const std::vector<float>& moving, int width, int height) {
  cv::Mat mask = finite_mask(moving, width, height);
  cv::erode(mask, mask, cv::Mat(), cv::Point(-1, -1), 3);  // image gradients near a hole are not the scene's
  return mask;
}

}  // namespace

namespace {

// The images' pyramids, level 0 the full frame (ECC's mask with them), and
// the signal ECC registers on at each level (RegistrationOptions::signal).
struct Pyramids {
  std::vector<cv::Mat> ref, mov, mask;
  std::vector<cv::Mat> ref_signal, mov_signal;
};

// The signal of one image (either of the pair) at one level: itself, or
// itself less its local mean over its pixels that are not holes (wrap() made
// their value 0; moving_mask() marks them, eroded).
cv::Mat signal_of(const cv::Mat& image, const cv::Mat& valid, const RegistrationOptions& options) {
  if (options.signal == RegistrationSignal::kIntensity) return image;
  return registration_detail::less_local_mean(image, valid, options.local_mean_sigma_px);
}

// `with_signal`: also the signal at every level (the still decision's), else none.
Pyramids pyramids_of(const cv::Mat& ref, const cv::Mat& mov, const cv::Mat& mask, const cv::Mat& ref_valid,
                     const RegistrationOptions& options, bool with_signal) {
  if (options.signal == RegistrationSignal::kLessLocalMean &&
      !(options.local_mean_sigma_px > 0 && options.local_mean_sigma_px <= 1000))
    throw RegistrationError("registration: local_mean_sigma_px must be in (0, 1000] px, got " +
                            std::to_string(options.local_mean_sigma_px));
  Pyramids p{{ref}, {mov}, {mask}, {}, {}};
  std::vector<cv::Mat> ref_valid_levels{ref_valid};
  for (int l = 1; l < options.pyramid_levels && std::min(p.ref.back().cols, p.ref.back().rows) >= 64; ++l) {
    cv::Mat r, m, k, v;
    cv::pyrDown(p.ref.back(), r), cv::pyrDown(p.mov.back(), m);
    cv::resize(p.mask.back(), k, m.size(), 0, 0, cv::INTER_NEAREST);
    cv::erode(k, k, cv::Mat());  // pyrDown smears the border into the masked pixels
    cv::resize(ref_valid_levels.back(), v, r.size(), 0, 0, cv::INTER_NEAREST);
    cv::erode(v, v, cv::Mat());
    p.ref.push_back(r), p.mov.push_back(m), p.mask.push_back(k), ref_valid_levels.push_back(v);
  }
  for (std::size_t l = 0; with_signal && l < p.ref.size(); ++l) {
    p.ref_signal.push_back(signal_of(p.ref[l], ref_valid_levels[l], options));
    p.mov_signal.push_back(signal_of(p.mov[l], p.mask[l], options));
  }
  return p;
}

// ECC from level `coarsest` down to `finest` (≥ 1: coarse levels only),
// `warp` updated in place and left in the pixels of level finest − 1 (the
// translation doubled after each level). A coarse level that does not
// converge (a posed view's small footprint leaves little texture there) is
// skipped, its bit set in `skipped`: the finer levels start from the warp
// found so far. Level 0 must converge: its cv::Exception is rethrown.
// `on_signal`: ECC on the pyramids' signal (the still decision), else on the images as they are.
void ecc_levels(const Pyramids& p, int coarsest, int finest, const RegistrationOptions& options, cv::Mat& warp,
                double& correlation, std::uint32_t& skipped, bool on_signal = false) {
  for (int level = coarsest; level >= finest; --level) {
    const cv::Mat before = warp.clone();
    try {
      correlation = cv::findTransformECC(on_signal ? p.ref_signal[level] : p.ref[level],
                                         on_signal ? p.mov_signal[level] : p.mov[level], warp, cv::MOTION_EUCLIDEAN,
                                         cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS,
                                                          options.max_iterations, options.epsilon),
                                         p.mask[level], 5);
    } catch (const cv::Exception&) {
      if (level == 0) throw;
      warp = before;
      skipped |= 1u << level;
    }
    if (level > 0) warp.at<float>(0, 2) *= 2, warp.at<float>(1, 2) *= 2;
  }
}

int coarsest_level(const Pyramids& p) { return static_cast<int>(p.ref.size()) - 1; }

// Whether ECC's warp can be a subject's motion between two captures of one
// plan. ECC can "converge" on a featureless view to a warp no
// subject made between two captures of one plan: a smooth, nearly isotropic
// patch matches itself turned by tens of degrees about its centre, or slid
// away. Such a warp (more than kMaximumRotationDeg, or less than
// kMinimumOverlap of the frame left overlapping) is not.
bool is_plausible(const RegistrationResult& r, int width, int height) {
  return overlap_fraction(r, width, height) >= kMinimumOverlap && std::abs(r.rotation_deg) <= kMaximumRotationDeg;
}

// ECC's warp as a result, or the translation fallback where it is not plausible.
RegistrationResult plausible_or_fallback(const cv::Mat& warp, double correlation, std::uint32_t skipped,
                                         const cv::Mat& ref, const cv::Mat& mov, const cv::Mat& mask) {
  RegistrationResult result = from_warp(warp, correlation);
  result.skipped_levels = skipped;
  if (!is_plausible(result, ref.cols, ref.rows)) {
    const double overlap = overlap_fraction(result, ref.cols, ref.rows);
    RegistrationResult fallback = translation_fallback(
        ref, mov, mask, "registration (ECC) found an implausible warp: rotation " + std::to_string(result.rotation_deg) +
                            "°, " + std::to_string(100 * overlap) + "% of the frame overlapping");
    fallback.skipped_levels = skipped;
    return fallback;
  }
  return result;
}

// ECC from `warp` (the identity, or the coarser levels' answer) at levels
// `coarsest` down to 0, then the plausibility check.
RegistrationResult finish_registration(const Pyramids& p, int coarsest, const RegistrationOptions& options, cv::Mat warp,
                                       double correlation, std::uint32_t skipped) {
  try {
    ecc_levels(p, coarsest, 0, options, warp, correlation, skipped);
  } catch (const cv::Exception& e) {
    return translation_fallback(p.ref[0], p.mov[0], p.mask[0],
                                std::string("registration (ECC) did not converge at pyramid level 0: ") + e.what());
  }
  return plausible_or_fallback(warp, correlation, skipped, p.ref[0], p.mov[0], p.mask[0]);
}

}  // namespace

RegistrationResult estimate_registration(const std::vector<float>& reference, const std::vector<float>& moving,
                                         int width, int height, const RegistrationOptions& options) {
  // ECC ignores moving-image pixels that are not finite (e.g. outside a warp).
  const Pyramids p = pyramids_of(wrap(reference, width, height), wrap(moving, width, height),
                                 moving_mask(moving, width, height), finite_mask(reference, width, height), options, false);
  return finish_registration(p, coarsest_level(p), options, cv::Mat::eye(2, 3, CV_32F), 0, 0);
}

std::vector<float> warp_channel(const std::vector<float>& moving, int width, int height, const RegistrationResult& r) {
  if (moving.size() != static_cast<std::size_t>(width) * height)
    throw RegistrationError("warp: image size does not match " + std::to_string(width) + " × " + std::to_string(height));
  const cv::Mat src(height, width, CV_32F, const_cast<float*>(moving.data()));
  cv::Mat warp(2, 3, CV_32F);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) warp.at<float>(i, j) = static_cast<float>(r.warp[i][j]);
  cv::Mat dst;
  // Sources up to kWarpBorderPx outside the frame take the nearest edge
  // pixel (a sub-pixel warp turns no finite pixel into NaN); beyond, the
  // pixel was not seen by this capture: NaN.
  cv::warpAffine(src, dst, warp, src.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
  std::vector<float> out(dst.ptr<float>(), dst.ptr<float>() + static_cast<std::size_t>(width) * height);
  constexpr double kWarpBorderPx = 1.0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double sx = r.warp[0][0] * x + r.warp[0][1] * y + r.warp[0][2];
      const double sy = r.warp[1][0] * x + r.warp[1][1] * y + r.warp[1][2];
      if (sx < -kWarpBorderPx || sy < -kWarpBorderPx || sx > width - 1 + kWarpBorderPx || sy > height - 1 + kWarpBorderPx)
        out[static_cast<std::size_t>(y) * width + x] = std::numeric_limits<float>::quiet_NaN();
    }
  return out;
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


namespace {

// The coarse levels' answer (ECC from the identity down to level 1, the
// warp in the pixels of level 0).
struct Coarse {
  cv::Mat warp = cv::Mat::eye(2, 3, CV_32F);
  double correlation = 0;
  std::uint32_t skipped = 0;
};

Coarse coarse_levels(const Pyramids& p, const RegistrationOptions& options, bool on_signal) {
  Coarse c;
  ecc_levels(p, coarsest_level(p), 1, options, c.warp, c.correlation, c.skipped, on_signal);
  return c;
}

// The robust round's mask: the moving capture's pixels that follow one gain
// and offset against the reference (photometric_mask.hpp), within p.mask[0],
// the reference resampled by the identity or by `warp` (the coarse levels'
// answer), whichever leaves the smaller departures (a still pair is aligned
// by the identity, however far the outliers pulled the coarse levels; a moved
// pair by the coarse warp); p.mask rebuilt from it at every level as
// pyramids_of builds it. Returns the share left out (0: p.mask unchanged).
double exclude_photometric_outliers(Pyramids& p, const cv::Mat& ref_valid, const cv::Mat& warp) {
  registration_detail::PhotometricMask best;
  best.departure_scale = std::numeric_limits<double>::infinity();
  for (const cv::Mat& w : {cv::Mat(cv::Mat::eye(2, 3, CV_32F)), warp}) {
    cv::Mat ref_on_moving, ref_valid_on_moving;
    cv::warpAffine(p.ref[0], ref_on_moving, w, p.ref[0].size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    cv::warpAffine(ref_valid, ref_valid_on_moving, w, p.ref[0].size(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
    registration_detail::PhotometricMask found =
        registration_detail::photometric_consistency_mask(ref_on_moving, p.mov[0], p.mask[0] & ref_valid_on_moving);
    if (found.departure_scale < best.departure_scale) best = std::move(found);
  }
  if (best.outlier_share == 0) return 0;
  p.mask[0] = p.mask[0] & best.consistent;
  // At each coarser level the outliers' edges reach farther: pyrDown's and
  // ECC's own 5-tap smoothing (2 px of that level each side) blur them into
  // their neighbours, so the margin grows by 3 px of each level.
  const cv::Mat margin = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(7, 7));
  for (std::size_t l = 1; l < p.mask.size(); ++l) {
    cv::resize(p.mask[l - 1], p.mask[l], p.mov[l].size(), 0, 0, cv::INTER_NEAREST);
    cv::erode(p.mask[l], p.mask[l], margin);
  }
  return best.outlier_share;
}

// The moving capture's mask on the reference's grid (the pixel x of the
// reference is the moving capture's warp · x), for the checks on the warped capture.
cv::Mat mask_on_reference(const cv::Mat& moving_mask_px, const RegistrationResult& r) {
  cv::Mat warp(2, 3, CV_32F), out;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) warp.at<float>(i, j) = static_cast<float>(r.warp[i][j]);
  cv::warpAffine(moving_mask_px, out, warp, moving_mask_px.size(), cv::INTER_NEAREST | cv::WARP_INVERSE_MAP,
                 cv::BORDER_CONSTANT, 0);
  return out;
}

// The still decision (RegistrationOptions::decide_still_at_coarse_level):
// the coarse levels' answer (`coarse`, on the images; or, with the signal
// RegistrationOptions::signal, ECC on its coarse levels here), the noise of
// the unwarped pair's signal within p.mask; the coarse result when its
// motion is not significant (not warped: its residual_motion_px the motion
// found), nothing otherwise.
std::optional<RegistrationResult> decide_still(const Pyramids& p, const RegistrationOptions& options, const Coarse& coarse_found) {
  const int width = p.ref[0].cols, height = p.ref[0].rows;
  const bool on_signal = options.signal != RegistrationSignal::kIntensity;
  const Coarse c = on_signal ? coarse_levels(p, options, true) : coarse_found;
  const int coarsest = coarsest_level(p);
  const bool converged_somewhere = c.skipped != ((1u << (coarsest + 1)) - 2);
  RegistrationResult coarse = from_warp(c.warp, c.correlation);
  coarse.skipped_levels = c.skipped;
  if (!converged_somewhere || !is_plausible(coarse, width, height)) return std::nullopt;
  coarse.motion_noise_px = motion_noise_px(p.ref_signal[0], p.mov_signal[0], p.mask[0]);
  const double motion = corner_displacement_px(coarse, width, height);
  if (!std::isfinite(coarse.motion_noise_px) || motion_is_significant(coarse, motion)) return std::nullopt;
  coarse.residual_motion_px = motion;  // not warped: what remains is the motion found
  return coarse;
}

// The residual check and the noise on the warped capture; after a robust
// round (`robust_mask` not empty: the moving capture's) within that mask
// carried onto the reference's grid.
void check_warped(const cv::Mat& ref, const cv::Mat& ref_valid, const std::vector<float>& moving, const cv::Mat& robust_mask,
                  int width, int height, const RegistrationOptions& options, RegistrationResult& r) {
  const std::vector<float> warped = warp_channel(moving, width, height, r);
  const cv::Mat warped_image = wrap(warped, width, height);
  cv::Mat mask = moving_mask(warped, width, height);
  if (!robust_mask.empty()) mask &= mask_on_reference(robust_mask, r);
  RegistrationResult rest;
  if (r.method == RegistrationMethod::kTranslation) {
    // The residual by the method that found the warp (ECC would wander on
    // the featureless view that sent it to the fallback).
    rest = translation_fallback(ref, warped_image, mask, "the residual check");
  } else {
    RegistrationOptions check = options;
    check.pyramid_levels = 1;
    const Pyramids level0 = pyramids_of(ref, warped_image, mask, ref_valid, check, false);
    rest = finish_registration(level0, 0, check, cv::Mat::eye(2, 3, CV_32F), 0, 0);
  }
  r.residual_method = rest.method;
  r.residual_motion_px = corner_displacement_px(rest, width, height);
  r.motion_noise_px = motion_noise_px(ref, warped_image, mask);
}

// Whether the coarse levels found a subject's motion: ECC converged at one
// of them at least, to a plausible warp. Where not (a featureless view, on
// which ECC wanders and each tile's translation is a guess), the tiles are not asked.
bool coarse_is_a_motion(const Pyramids& p, const Coarse& c) {
  const int coarsest = coarsest_level(p);
  if (coarsest == 0) return true;  // no coarse level: the tiles from the identity
  const bool converged_somewhere = c.skipped != ((1u << (coarsest + 1)) - 2);
  return converged_somewhere && is_plausible(from_warp(c.warp, c.correlation), p.ref[0].cols, p.ref[0].rows);
}

// The tile consensus (RegistrationOptions::tile_consensus) from the
// identity, and from the coarse warp where that moves a corner by more than
// 1 px (beyond a tile's reach from the identity): whichever has the smaller noise.
registration_detail::TileMotion consensus_of_tiles(const Pyramids& p, const cv::Mat& ref_valid, const cv::Mat& coarse_warp) {
  const cv::Mat identity = cv::Mat::eye(2, 3, CV_32F);
  registration_detail::TileMotion best = registration_detail::tile_motion(p.ref[0], ref_valid, p.mov[0], p.mask[0], identity);
  if (corner_displacement_px(from_warp(coarse_warp, 0), p.ref[0].cols, p.ref[0].rows) > 1.0) {
    registration_detail::TileMotion from_coarse =
        registration_detail::tile_motion(p.ref[0], ref_valid, p.mov[0], p.mask[0], coarse_warp);
    if (from_coarse.measured && (!best.measured || from_coarse.noise_px < best.noise_px)) best = std::move(from_coarse);
  }
  return best;
}

RegistrationResult tiles_result(const registration_detail::TileMotion& tiles, RegistrationResult r) {
  const RegistrationResult t = from_warp(tiles.warp, r.correlation);
  std::copy(&t.warp[0][0], &t.warp[0][0] + 6, &r.warp[0][0]);
  r.shift_x_px = t.shift_x_px, r.shift_y_px = t.shift_y_px, r.rotation_deg = t.rotation_deg;
  r.tiles_measured = tiles.tiles_measured, r.tiles_kept = tiles.tiles_kept;
  return r;
}

// The still decision by tiles: their motion is not significant against their noise.
std::optional<RegistrationResult> still_by_tiles(const registration_detail::TileMotion& tiles, const Coarse& c, int width,
                                                 int height) {
  RegistrationResult r = tiles_result(tiles, RegistrationResult{});
  r.method = RegistrationMethod::kTiles, r.skipped_levels = c.skipped, r.correlation = c.correlation;
  r.motion_noise_px = tiles.noise_px;
  const double motion = corner_displacement_px(r, width, height);
  if (motion_is_significant(r, motion)) return std::nullopt;
  r.residual_motion_px = motion;  // not warped: what remains is the motion found
  return r;
}

// ECC's warp where it agrees with the tiles' (within kMotionSignificance of
// their noise, or kWarpThresholdPx, at every corner), else the tiles'.
RegistrationResult agreed_with_tiles(const RegistrationResult& r, const registration_detail::TileMotion& tiles, int width,
                                     int height) {
  const RegistrationResult t = tiles_result(tiles, r);
  // The two warps' largest distance at a corner: the displacement of r − t + identity.
  RegistrationResult difference;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) difference.warp[i][j] = r.warp[i][j] - t.warp[i][j] + (i == j ? 1.0 : 0.0);
  const double apart = corner_displacement_px(difference, width, height);
  const bool departs = apart > std::max(kWarpThresholdPx, kMotionSignificance * tiles.noise_px);
  RegistrationResult kept = departs ? t : r;
  if (departs) kept.method = RegistrationMethod::kTiles;
  kept.tiles_measured = tiles.tiles_measured, kept.tiles_kept = tiles.tiles_kept;
  return kept;
}

}  // namespace

RegistrationResult register_channel(const std::vector<float>& reference, const std::vector<float>& moving, int width,
                                    int height, const RegistrationOptions& options) {
  const cv::Mat ref = wrap(reference, width, height), mov = wrap(moving, width, height);
  const cv::Mat ref_valid = finite_mask(reference, width, height);
  Pyramids p = pyramids_of(ref, mov, moving_mask(moving, width, height), ref_valid, options,
                           options.decide_still_at_coarse_level);
  Coarse c;
  double outlier_share = 0;
  int coarsest = coarsest_level(p);
  if (coarsest > 0 && options.signal == RegistrationSignal::kIntensity) {
    // The coarse levels, then the robust round: where some regions do not
    // follow the captures' one gain (ink, marker), they are left out and the
    // coarse levels run again from the identity; level 0 goes on from them.
    c = coarse_levels(p, options, false);
    if (options.exclude_photometric_outliers && (outlier_share = exclude_photometric_outliers(p, ref_valid, c.warp)) > 0)
      c = coarse_levels(p, options, false);
    coarsest = 0;
  }
  std::optional<registration_detail::TileMotion> tiles;
  if (options.tile_consensus && coarse_is_a_motion(p, c)) {
    tiles = consensus_of_tiles(p, ref_valid, c.warp);
    if (!tiles->measured) tiles.reset();
  }
  if (tiles && options.decide_still_at_coarse_level) {
    if (auto still = still_by_tiles(*tiles, c, width, height)) {
      still->photometric_outlier_share = outlier_share;
      return *still;
    }
  } else if (options.decide_still_at_coarse_level && coarsest_level(p) > 0) {
    if (auto still = decide_still(p, options, c)) {
      still->photometric_outlier_share = outlier_share;
      return *still;
    }
  }
  // Moved: the images as they are; with the signal every level afresh.
  RegistrationResult r = finish_registration(p, coarsest, options, c.warp, c.correlation, c.skipped);
  if (tiles && r.method == RegistrationMethod::kEcc) r = agreed_with_tiles(r, *tiles, width, height);
  r.photometric_outlier_share = outlier_share;
  check_warped(ref, ref_valid, moving, outlier_share > 0 ? p.mask[0] : cv::Mat(), width, height, options, r);
  if (tiles) r.motion_noise_px = tiles->noise_px;
  return r;
}

std::vector<RegistrationResult> register_channels(const std::vector<RegistrationPair>& pairs, int width, int height,
                                                  const RegistrationOptions& options) {
  std::vector<RegistrationResult> results(pairs.size());
  std::vector<std::exception_ptr> errors(pairs.size());
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t k; (k = next++) < pairs.size();) {
      try {
        results[k] = register_channel(pairs[k].reference, pairs[k].moving, width, height, options);
      } catch (...) {
        errors[k] = std::current_exception();
      }
    }
  };
  const std::size_t cores = options.threads > 0 ? options.threads : std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> workers;
  for (std::size_t t = 1; t < std::min(cores, pairs.size()); ++t) workers.emplace_back(work);
  work();
  for (auto& w : workers) w.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  return results;
}

bool motion_is_significant(const RegistrationResult& registration, double motion_px) {
  return motion_px > std::max(kWarpThresholdPx, kMotionSignificance * registration.motion_noise_px);
}

}  // namespace chromo::session
