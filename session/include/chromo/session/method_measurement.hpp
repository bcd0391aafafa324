#pragma once
// A plan's captures of one subject → the estimator's input: one route for
// every plan, the plan's recipe (MeasurementRecipe, below) saying which
// channels are formed.
//
// A standard session (docs/daemon.md) captures, with one camera: a dark frame,
// then the white reference target and the subject, each under D65' (the
// broadband D65 metamer), W57 alone and W57+blue. build_measurement() with
// standard_recipe() turns the (mean) images of those seven captures into the
// measurement of the seed method, pixel by pixel:
//
//   albedo_k,c  = ρ_white · (subject_k,c − dark_c) / (white_k,c − dark_c)     k = each illumination, c = R, G, B
//   measured    = (albedo_D65',R, albedo_D65',G, albedo_D65',B, blue)
//   blue        = ρ_white · (subject_mix,B − subject_W57,B) / (white_mix,B − white_W57,B)
//
// with the illuminants D65' (R, G, B) and "mix − W57" (B). The subject moves
// between captures, the white target does not (it is the sphere's flat field):
// each capture is normalised by its own white first, then the W57 and
// W57+blue albedo images are registered to the D65' one (ECC on G,
// registration.hpp) and warped onto its grid, and the blue-only channel is
// formed there as a_mix,B·w_mix,B − s·a_W57,B·w_W57,B over w_mix,B − s·w_W57,B
// (s = t_mix/t_W57, below; 1 at one exposure)
// (w = white − dark at the reference pixel), which equals the formula above
// when nothing moved. A capture whose registration moves no image corner by
// more than 0.1 px is not warped (that motion is registration noise, and a
// warp would blank the border row); the report says which were warped.
//
// Footprint: a white reference's mean and noise are taken over the camera's
// footprint of the target only (white_reference_footprint below); outside
// the footprint of any white a pixel uses, its albedo is NaN and it is
// listed in Measurement::no_reference.
//
// Noise (measurement.hpp's model), estimated from the captures themselves:
// the per-pixel noise variance of the dark and of each white image is half
// the mean squared difference of horizontally adjacent pixels (a flat target:
// slow flat-field variation cancels). Each image is the mean of its step's
// frames (RgbImage::frames = N), so that variance is already the N-frame
// mean's (V_d, V_w); the per-frame read variance is R = N_d·V_d and the
// per-frame shot variance of the white S = N_w·V_w − R. For albedo a under
// capture k, channel c, with W = mean(white − dark), N_s subject frames and
// the subject at g times its white's exposure (ExposureLinearity below):
//   σ²(a) = ρ²(R + S·g·a/ρ)/(N_s·g²·W²)   (subject)
//         + a²·V_w/W²                      (white: the albedo divides by it)
//         + (a − ρ/g)²·V_d/W²              (dark: subtracted from both)
//   → read_sigma² = ρ²(R/N_s + V_d)/(g²W²), shot_coefficient = ρ(S/N_s − 2V_d)/(g·W²) (≥ 0),
//     white_coefficient = (V_w + V_d)/W²,
// saturation_albedo = ρ·(1 − dark)/(g·W). The blue-only channel may
// combine two exposures t_mix and t_W57 (RgbImage::exposure_us): the W57
// capture's signals are scaled by s = t_mix/t_W57 onto the mix's exposure
// (a camera linear in exposure above the dark; s = 1 when both share one
// exposure, as the standard plans do), and with D = W_mix,B − s·W_W57,B,
// the subjects' shot noise taken at the blue albedo a itself:
//   read_sigma² = ρ²[R/(N_s,mix·g_mix²) + s²·R/(N_s,W57·g_W57²)] / D²,
//   shot_coefficient = ρ[S_mix/(N_s,mix·g_mix) + s²·S_W57/(N_s,W57·g_W57)] / D²,
//   white_coefficient = (V_w,mix + s²·V_w,W57) / D²
// (the dark cancels at s = 1; at s ≠ 1 its small share is left out).
// Measured (bench/noise_model_bench.cpp): on the lab's skin the variance of
// noisy − noise-free renders is 0.97-1.02 of this figure in every channel.
// Saturation: a pixel whose raw subject value is at or above 0.999 of full
// scale in a channel gets that channel set to the channel's saturation albedo
// (so the estimator flags it kSaturated); saturation_albedo = ρ·(1 − dark)/W.
//
// Errors: std::invalid_argument naming the capture (sizes differ, a white no
// brighter than the dark or saturated on more than 0.1% of its pixels, no
// blue left in W57+blue − W57); RegistrationError
// when a capture cannot be registered. Thread rules: a pure function.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "chromo/estimation/measurement.hpp"
#include "chromo/session/registration.hpp"
#include "chromo/session/surface_factors.hpp"

namespace chromo::session {

// A linear RGB image in units of the camera's full scale (0-1, dark level
// included): the mean of one step's frames after demosaicing.
struct RgbImage {
  int width = 0, height = 0;
  std::array<std::vector<float>, 3> planes;  // R, G, B; width × height each, row-major
  std::uint32_t frames = 1;  // how many frames this is the mean of
  double exposure_us = 0;    // the frames' exposure (0: not known; taken as equal to the others')
  std::size_t pixels() const { return static_cast<std::size_t>(width) * height; }
};

struct IlluminatedCapture {
  std::string name;               // "D65'", "W57", "W57+blue"
  spectral::Spectrum illuminant;  // what the sphere emitted (any common scale)
  RgbImage white, subject;        // the white reference target and the subject under it
  // The white target under the same light at a second exposure (the subject
  // at another exposure than its white: the linearity check, below). Absent:
  // the camera's linearity in exposure is assumed (ExposureLinearity::checked false).
  std::optional<RgbImage> white_linearity;
  // The white's signal above the dark is multiplied by this per channel
  // (R, G, B) where the albedo is formed: ∫S_c·E_subject / ∫S_c·E_white when
  // the LEDs ran at other temperatures for the subject than for the white
  // (session_captures.cpp, docs/calibration.md "The thermal model"); 1 else.
  std::array<double, 3> white_signal_scale{1.0, 1.0, 1.0};
};

// Exposure per capture (docs/daemon.md "Subject exposure"): a subject
// may be taken at g = t_subject / t_white times its white's exposure (a skin
// 2-5× darker than the white then fills the sensor as the white does). The
// white is not re-taken at the subject's exposure (it would clip): its signal
// is scaled by the exposure ratio,
//   albedo = ρ · (subject − dark) / (g · (white − dark)),
// which holds for a camera linear in exposure above the dark (the virtual
// lab's: no dark current, so one dark serves every exposure; a camera with
// dark current needs a dark per exposure, which this builder does not take).
// The check: the white at a second exposure t2 (white_linearity, e.g. t_white/g,
// so its signal spans the same range of the sensor as the subject's against
// the white); the signal ratio mean(white − dark)/mean(white_linearity − dark)
// over the white's footprint, per channel with signal above 1% of full scale
// in both, must be t_white/t2 within linearity_tolerance (relative), else
// std::invalid_argument naming the capture, the exposures and both ratios.
inline constexpr double kMaxSubjectExposureRatio = 64;
inline constexpr double kDefaultLinearityTolerance = 0.02;
struct ExposureLinearity {
  std::string capture;
  double subject_exposure_ratio = 1;  // g = t_subject / t_white
  double exposure_ratio = 0;          // t_white / t2 of the check (0: not checked)
  double signal_ratio = 0;            // its worst channel's signal ratio
  double deviation = 0;               // signal_ratio / exposure_ratio − 1 (worst channel)
  bool checked = false;
};
// The check alone (capture.white_linearity must be present): throws as above.
ExposureLinearity check_exposure_linearity(const IlluminatedCapture& capture, const RgbImage& dark,
                                           double tolerance = kDefaultLinearityTolerance);

// Metering the subject (exposure per capture): from a frame of the subject at
// its white's exposure, the exposure ratio g that puts the `percentile` of
// the subject's pixels in its brightest channel (the channel whose percentile
// is highest) at `fill` of full scale, the camera taken as linear above the
// dark: g = (fill − dark) / (level − dark), clamped to [1, max_ratio] (never
// shorter than the white's, at most max_ratio longer). Pixels above the
// percentile may clip: build_measurement flags a pixel saturated where
// any raw subject value reaches 0.999 of full scale, whatever the exposure.
// Pixels outside `mask` (when given: e.g. the white's footprint) are not counted.
struct SubjectMetering {
  double fill = 0.85;        // (0, 1)
  double percentile = 0.99;  // (0, 1]
  double max_ratio = 8;      // [1, kMaxSubjectExposureRatio]
};
struct SubjectMeteringResult {
  double exposure_ratio = 1;
  int channel = 0;         // the brightest channel (R, G, B)
  double level = 0;        // its percentile, share of full scale (dark included)
  bool capped = false;     // max_ratio reached before fill
};
// The ratio alone from the brightest channel's percentile level and its dark
// level (shares of full scale), as above; max_ratio when level ≤ dark.
double subject_exposure_ratio(double level, double dark, double fill, double max_ratio);
// Throws std::invalid_argument naming the field for bad options or images.
SubjectMeteringResult meter_subject_exposure(const RgbImage& subject, const RgbImage& dark, const SubjectMetering& options,
                                             const std::vector<std::uint8_t>& mask = {});

// How one channel of a measurement is formed from the captures
// (MeasurementRecipe): the albedo of capture `capture` in camera channel
// `camera_channel`, named "<capture's name>.<R|G|B>"; or, with `less`, a
// difference channel (the method's blue-only one, above): capture's albedo
// less capture `less`'s, each weighted by its white's signal in that camera
// channel (s = t_capture/t_less of their whites), named "<name>.<R|G|B>",
// its illuminant capture's − less's (negative parts 0). Refused (naming both
// captures) where the whites' difference is ≤ 0.001 of full scale.
struct ChannelRecipe {
  std::size_t capture = 0;
  int camera_channel = 0;  // R, G, B
  std::optional<std::size_t> less;
  std::string name;  // a difference channel's ("blue")
};

// What a plan measures of its captures: its channels, and the camera channel
// on which each capture after the first is registered to the first.
struct MeasurementRecipe {
  std::vector<ChannelRecipe> channels;      // empty: R, G, B of every capture, in order
  std::optional<int> registration_channel;  // none: the moving capture's white's brightest channel
};

// The standard plan's recipe (the method's), for the captures D65', W57,
// W57+blue in that order: D65' R, G, B and blue.B = W57+blue − W57, every
// capture registered on G.
MeasurementRecipe standard_recipe();

// The captures of any plan (session_plan.hpp: the standard plan, the
// multispectral one, an operator's) and what is measured of them: the dark
// and, per illumination state that has a subject step, its white reference
// and the subject, in plan order (the standard plan: D65', W57, W57+blue).
// Every capture is photographed (Measurement::photographs).
struct Captures {
  spectral::CameraSensitivity camera;
  double white_reflectance = 0.99;  // ρ_white of the reference target
  double linearity_tolerance = kDefaultLinearityTolerance;
  RgbImage dark;
  std::vector<IlluminatedCapture> captures;
  MeasurementRecipe recipe;
  // A polarised sphere's standard plan (standard_plan({.polarised = true})):
  // the captures above are cross-polarised and this is the first one's
  // light parallel-polarised (its own white): the surface maps are made from
  // it (Measurement::surface). Absent on an unpolarised sphere.
  std::optional<IlluminatedCapture> parallel;
  // What the cross and parallel captures keep of the surface reflection
  // (surface_factors.hpp: the films as the estimator knows them). With a
  // parallel capture and these, the surface maps are corrected for the
  // films' extinction and the cross captures for the surface light they
  // still hold (Measurement::surface_correction); without them the
  // surface map is (parallel − cross)/2 of G, uncorrected, as before.
  std::optional<SurfaceFactors> surface_factors;
};

// A capture of the subject as camera RGB albedo (white = 1) on the reference
// grid: what the reconstruction is compared with under that illuminant.
struct Photograph {
  std::string name;
  spectral::Spectrum illuminant;
  std::vector<Eigen::Vector3d> rgb;
  // Its R, G, B albedo's noise (read and shot, from its own dark and white as
  // the estimator's channels'): what the photograph alone puts into a relit
  // comparison against it (maps::RelitComparison::photograph_noise). Unset
  // (nullopt) for a photograph of unknown noise.
  std::optional<std::array<estimation::ChannelNoise, 3>> noise;
};

// The cross captures are corrected by the surface map where the G surface
// map stands this many σ above the sheen: below it the highlight's surface
// light left in the cross capture is at most c_cross·3σ (about 0.0005 albedo
// in the blue at 1:50), under the cross capture's own noise, and nothing is
// subtracted (no noise added on skin; a one-sided 3σ test passes 0.13% of
// skin's pixels).
inline constexpr double kSurfaceCorrectionSigmas = 3.0;

// What a polarised measurement's surface correction used
// (Measurement::surface_correction). At namespace scope: clang rejects
// std::optional::emplace() of a nested struct with member initialisers.
struct SurfaceCorrection {
  std::string source;                       // SurfaceFactors::source
  std::array<double, 3> parallel_minus_cross{};  // c_parallel,c − c_cross,c of D65' (the surface maps' divisor)
  std::vector<std::array<double, 3>> cross_factor;  // c_cross,c per capture (D65', W57, W57+blue)
  std::array<double, 3> sheen_reference{};  // per channel: median of S_c, capped at F(0°)
  std::size_t corrected_pixels = 0;         // where S_c itself was subtracted
};

struct Measurement {
  estimation::MeasurementSet set;   // the recipe's channels (the standard plan: D65'.R, D65'.G, D65'.B, blue.B)
  int width = 0, height = 0;
  std::vector<float> measured;  // pixel-major, set.size() values per pixel
  std::vector<RegistrationReport> registration;
  std::vector<Photograph> photographs;  // one per capture (D65', W57, W57+blue)
  std::size_t saturated_pixels = 0;     // pixels with a raw subject value at full scale
  // Each capture's exposure and frame count, in the order dark, then white
  // and subject of each capture, the parallel one last ("white D65'", "subject W57", ...).
  struct CaptureExposure {
    std::string capture;
    double exposure_us = 0;
    std::uint32_t frames = 1;
  };
  std::vector<CaptureExposure> exposures;
  // Per capture (D65', W57, W57+blue[, D65' parallel] or the plan's): the
  // subject's exposure ratio and its linearity check.
  std::vector<ExposureLinearity> linearity;
  // 1 where the pixel is outside the camera's footprint of a white reference
  // it needs (white_reference_footprint): no albedo there (the estimator's
  // maps are NaN and flagged no_reference, maps::estimate_captures).
  std::vector<std::uint8_t> no_reference;
  std::size_t no_reference_pixels = 0;
  // With a D65' parallel capture (docs/polarisation.md, "Estimation
  // outputs"): the surface map per pixel from D65' parallel (against its own
  // parallel white, on the cross D65' grid as captured: not registered,
  // measurement_surface.hpp says why) and the cross D65' albedo,
  //   S_c = (a_parallel,c − a_cross,c) / (c_parallel,c − c_cross,c)
  // with the channel's surface factors (surface_factors.hpp) when
  // Captures::surface_factors is given: the surface layer in albedo
  // units, corrected for the films' extinction; without them the divisor is
  // 2 (the ideal films'), so S is (ER − 1)²/(ER + 1)² of the surface layer
  // (2% short at 1:200). `surface` is G (the highlight flag's, with its σ
  // per pixel from the two captures' noise models, measurement.hpp's);
  // `surface_red`, `surface_blue` the other channels. All empty without a
  // parallel capture.
  std::vector<float> surface, surface_sigma, surface_red, surface_blue;
  // What was done with the surface light (present when the surface factors
  // were known): where the G surface map stands at least
  // kSurfaceCorrectionSigmas σ above the sheen reference F, the cross
  // captures' albedo in `measured` had c_cross,c·(S_c − F_c) subtracted per
  // channel (the highlight's surface light; S_G for a channel whose parallel
  // capture is saturated). Elsewhere, and for the sheen everywhere, the
  // captures are as before: skin's estimate is unchanged (the sheen leaves
  // c_cross·F, 0.0017 albedo in B at 1:200, on every pixel alike). The
  // photographs stay as captured.
  std::optional<SurfaceCorrection> surface_correction;
  bool polarised() const { return !surface.empty(); }
};

// Where a camera sees the white reference target (issue 21: a posed camera
// sees the planar target in perspective, dark around it). With the signal
// s = Σ_RGB (white − dark) per pixel, a pixel is inside when s exceeds
// max(kFootprintShare · the 99th percentile of s, kFootprintNoiseSigmas · the
// noise of s on an unlit pixel, √(2·Σ dark variance)); a frame lit nowhere
// above that is inside everywhere (the white checks then name the capture).
// interior: inside pixels whose 8 neighbours are inside too; the white's mean
// and noise are taken there (an edge pixel sees part target, part dark). A
// camera whose target fills the frame has every pixel inside and interior.
inline constexpr double kFootprintShare = 0.25;
inline constexpr double kFootprintNoiseSigmas = 8;
struct ReferenceFootprint {
  std::vector<std::uint8_t> inside, interior;
  std::size_t inside_pixels = 0;
  double threshold = 0;  // on s, share of full scale
};
ReferenceFootprint white_reference_footprint(const RgbImage& white, const RgbImage& dark);

// The captures → their measurement: each capture's albedo against its own
// white (the formula above), every capture after the first registered to
// the first (ECC on the recipe's registration channel, the same channel of
// the first) and warped when it moved, the recipe's channels formed on the
// first capture's grid, the noise of each from the dark and white captures;
// the surface maps when a parallel capture is present. Errors as above,
// naming the capture; no capture is std::invalid_argument.
Measurement build_measurement(const Captures& captures, const RegistrationOptions& options = {});

// The measurement set alone (illuminants and noise), from the dark and white
// captures: known before the subject is captured, so a streaming caller can
// build the forward table early. Equal to build_measurement(...).set.
estimation::MeasurementSet measurement_set_from_references(const Captures& captures);

// The illuminants of the photographs the builder makes (Measurement::
// photographs, in order), known from the white references as the set is: a
// streaming caller prepares the relit comparison's table early.
std::vector<spectral::Spectrum> photograph_illuminants(const Captures& captures);

}  // namespace chromo::session
