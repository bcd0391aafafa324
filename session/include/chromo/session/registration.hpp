#pragma once
// Registration of the captures of one subject (the subject moves between the
// broadband and the W57+blue captures): OpenCV's ECC (cv::findTransformECC,
// Euclidean motion: shift + rotation) on one channel the two images share,
// then a warp of every channel of the moving image onto the reference.
//
// Residual motion: after warping, ECC is run once more between the reference
// and the warped image; the largest displacement that remaining transform
// gives any image corner is reported (pixels). A coarse pyramid level where
// ECC does not converge is skipped (listed in skipped_levels; the next finer
// level starts from the warp so far).
//
// Fallback for featureless captures (a polarised session's cross captures
// have lost the highlight, which gives a smooth view most of its texture):
// when the finest level does not converge, or ECC's warp is not a subject's
// motion between two captures of one plan (turned by more than 10°, or less
// than half of the frame left overlapping: on a smooth, nearly isotropic
// view ECC "converges" to such warps, −78° on the test's), a global translation is
// estimated instead by gradient least squares (Gauss-Newton on
// moving(x + t) ≈ a·reference(x) + b, the gain a and offset b absorbing the
// illuminants' difference), with its standard error from the fit's residual
// (σ_t² = σ_r² · (JᵀJ)⁻¹, pixels taken as independent). It is used only when
// 3σ_t ≤ kTranslationFallbackUncertaintyPx on both axes: the motion is then
// measured to a fraction of a pixel even where ECC found no optimum
// (method "translation", its σ reported); otherwise RegistrationError names
// what failed (ECC's error and the fallback's uncertainty) and nothing is
// warped.
//
// Thread rules: free functions, reentrant (OpenCV may use its own threads).

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace chromo::session {

class RegistrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// How a registration was found: ECC, the translation fallback above, or the
// consensus of tiles (RegistrationOptions::tile_consensus: where ECC's warp
// departs from it significantly). One byte, so RegistrationResult stays
// trivially copyable (cached by the rendered session, files/binary_cache.hpp).
enum class RegistrationMethod : std::uint8_t { kEcc = 0, kTranslation = 1, kTiles = 2 };
inline const char* registration_method_name(RegistrationMethod m) {
  return m == RegistrationMethod::kTranslation ? "translation" : m == RegistrationMethod::kTiles ? "tiles" : "ECC";
}

// What the still decision (RegistrationOptions::decide_still_at_coarse_level)
// registers on: the channel as it is (the default), or the channel less its
// local mean (Gaussian, local_mean_sigma_px at each pyramid level). A still
// real-skin scene whose ink and marker change contrast between the LEDs pulls
// ECC on the channel as it is (0.355 px on the six LEDs); less its local mean
// it does not (src/registration_signal.hpp says why; docs/estimation.md
// "Registration of a still scene" has the figures). Not the default: on a
// smooth, featureless view (the polarised cross capture) the coarse levels of
// the signal find too little of a real 0.5 px motion and call it still
// (Registration.AFeaturelessView... fails with it). A capture found moved is
// registered on the channel as it is, every level, as without the decision.
enum class RegistrationSignal : std::uint8_t { kIntensity = 0, kLessLocalMean = 1 };

struct RegistrationOptions {
  RegistrationSignal signal = RegistrationSignal::kIntensity;
  double local_mean_sigma_px = 8;  // in (0, 1000] px; see RegistrationSignal
  int max_iterations = 200;
  double epsilon = 1e-6;
  int pyramid_levels = 3;  // coarse-to-fine: handles shifts of tens of pixels
  // register_channels: pairs registered at once (0: the machine's cores; 1:
  // one after another). The results do not depend on it. Default 1: at once
  // measured ×0.72-1.06 of one by one (median 0.95, one run each at load
  // 12-14 on 2 shared cores: estimate_stages_bench --chain; docs/estimation.md).
  int threads = 1;
  // register_channel: decide a still subject before the full-resolution
  // work. ECC on the coarse pyramid levels only (≥ 1) of `signal`, and the
  // registration noise (motion_noise_px) of the unwarped pair's signal; when
  // that coarse motion is not significant (motion_is_significant), the
  // result is the coarse warp, which callers then do not warp, its
  // residual_motion_px that motion (no warp leaves it), and level-0 ECC, the
  // warp and the residual check are skipped. Otherwise the result is bit for
  // bit that of false (test Registration.AStillSceneIsDecidedAt...; with
  // signal kIntensity level 0 goes on from the coarse warp).
  // false: every level on the channel as it is, the warp and the residual check.
  bool decide_still_at_coarse_level = true;
  // register_channel's robust round (signal kIntensity, images of ≥ 2
  // pyramid levels): after the coarse levels, the moving capture's pixels
  // whose ratio to the reference departs from the captures' one gain (ink,
  // marker, highlights: src/photometric_mask.hpp; the reference aligned by
  // the identity or the coarse warp, whichever departs less) are left out of
  // every level, with a margin, the coarse levels run again from the
  // identity, and the still decision, level 0, the residual check and the
  // noise use that mask. A pair without such pixels is registered exactly as
  // without the round. Opt-in (false by default): on the real-skin benches it
  // halves the still six-LED scene's pull and the error on a known 0.4 px
  // motion, but still warps one of five still captures and is slower
  // (docs/estimation.md "A robust round", still37b; measured with
  // tile_consensus off, which the tile consensus now makes unnecessary).
  bool exclude_photometric_outliers = false;
  // register_channel's motion statistic (on by default; src/tile_motion.hpp):
  // after the coarse levels, the translation of each tile (16-48 px, its own
  // gain and offset; half of them at least with a texture 4× above the noise
  // in their gradients, else no consensus), a shift and rotation fitted to them with the
  // disagreeing tiles left out, and its noise from the kept tiles' spread
  // about the fit (motion_noise_px). Captures under different LEDs pull ECC
  // where ink, marker or subjects change contrast, but each tile its own way;
  // a subject's motion moves every tile alike. The tiles start from the
  // identity, and also from ECC's coarse warp where that moves a corner by
  // more than 1 px; the start whose fit has the smaller noise is kept. Used
  // where at least 8 tiles measure and ECC's coarse levels found a plausible
  // motion (else, a featureless or smooth view: as without it). With
  // decide_still_at_coarse_level, a tiles' motion not significant against
  // that noise (motion_is_significant) is the still decision in place of the
  // block rule (method kTiles, not warped, level 0 skipped). A moved capture
  // is registered by ECC as before, and ECC's warp (not the translation
  // fallback's) replaced by the tiles' (method kTiles) where the two differ
  // at a corner by more than max(kWarpThresholdPx, kMotionSignificance × that
  // noise). false: ECC alone with the block noise (`chromo estimate
  // --registration-tiles off`, chromod's estimation.registration_tiles).
  // docs/estimation.md "Registration of a still scene by tiles" (still37c,
  // still37d) has the figures.
  bool tile_consensus = true;
};

struct RegistrationResult {
  double shift_x_px = 0, shift_y_px = 0;  // moving → reference
  double rotation_deg = 0;
  double correlation = 0;                 // ECC's enhanced correlation at the end
  double residual_motion_px = 0;          // see above
  double warp[2][3] = {{1, 0, 0}, {0, 1, 0}};
  std::uint32_t skipped_levels = 0;       // bit l set: coarse pyramid level l (> 0) did not converge, skipped
  RegistrationMethod method = RegistrationMethod::kEcc;
  // How the residual check (register_channel) measured residual_motion_px:
  // ECC on the warped capture, or the fallback where ECC gave no answer
  // there (an aligned featureless pair is where ECC fails most).
  RegistrationMethod residual_method = RegistrationMethod::kEcc;
  double translation_sigma_px = 0;        // the fallback's larger standard error of the shift (0 for ECC)
  // The registration's own noise (register_channel; 0 until measured): with
  // the tile consensus measured, its standard error at the worst corner;
  // otherwise the standard error of the shift from its spread between blocks of the frame.
  double motion_noise_px = 0;
  // The tile consensus (RegistrationOptions::tile_consensus): tiles that
  // measured their translation, and those kept in the fit (0, 0: not run).
  std::int32_t tiles_measured = 0, tiles_kept = 0;
  // The robust round (register_channel): the share of the moving capture's
  // pixels left out as not following one gain and offset (0: none, the
  // registration is that of one round).
  double photometric_outlier_share = 0;
};

// The fallback's acceptance: three standard errors of the translation.
inline constexpr double kTranslationFallbackUncertaintyPx = 0.3;

// reference_channel, moving_channel: width × height floats (row-major).
RegistrationResult estimate_registration(const std::vector<float>& reference_channel,
                                         const std::vector<float>& moving_channel, int width, int height,
                                         const RegistrationOptions& options = {});

// Warps one channel of the moving image onto the reference's pixel grid
// (bilinear; a source up to 1 px outside the frame takes the nearest edge
// pixel, so a sub-pixel warp leaves every pixel finite; pixels farther
// outside were not seen by the capture: NaN, so the estimator flags them).
std::vector<float> warp_channel(const std::vector<float>& moving_channel, int width, int height,
                                const RegistrationResult& registration);

// Registration then the residual check on the warped image.
RegistrationResult register_channel(const std::vector<float>& reference_channel,
                                    const std::vector<float>& moving_channel, int width, int height,
                                    const RegistrationOptions& options = {});

// The channels of one capture pair to register: the reference's and the
// moving capture's, width × height floats each.
struct RegistrationPair {
  std::vector<float> reference, moving;
};

// register_channel for every pair (a plan's captures against its first),
// up to options.threads pairs at once: each pair's ECC is mostly serial, so
// a plan of several captures keeps the cores busy. Results in the pairs'
// order, equal to one after another; a pair's exception is rethrown (the
// first pair's in order that threw).
std::vector<RegistrationResult> register_channels(const std::vector<RegistrationPair>& pairs, int width, int height,
                                                  const RegistrationOptions& options = {});

// Largest displacement the registration's transform gives an image corner.
double corner_displacement_px(const RegistrationResult& registration, int width, int height);

// A capture whose registration moves no image corner by more than this is not
// warped: that motion is registration noise, and a warp would only blur.
inline constexpr double kWarpThresholdPx = 0.1;
// Nor is one whose motion is within this many of its own noise
// (RegistrationResult::motion_noise_px): a still scene keeps the identity.
// 4 ≈ the two-sided 99.9% quantile of Student's t with 15 degrees of freedom
// (the 4 × 4 blocks' spread estimates the noise): a warp of a still scene
// should be rare, and a moving subject moves by far more (whole pixels).
inline constexpr double kMotionSignificance = 4.0;
// Whether a capture that register_channel registered with this corner motion
// is warped: motion_px > max(kWarpThresholdPx, kMotionSignificance · motion_noise_px).
bool motion_is_significant(const RegistrationResult& registration, double motion_px);

// One capture registered to the reference, as summary.json reports it.
struct RegistrationReport {
  std::string image, reference, channel;
  RegistrationResult result;
  double motion_px = 0;  // corner_displacement_px of the found transform
  bool warped = false;   // motion_px > kWarpThresholdPx: the capture was warped onto the reference
};

}  // namespace chromo::session
