#pragma once
// The virtual lab's standard session (session_plan.hpp: dark, then white and
// subject under D65', W57 and W57+blue) rendered in this process, without
// devices or network, and turned into the estimator's measurement by the
// daemon's own path. Frames with known truth for the estimation bench (5 MP)
// and tests (tiny). Each stage is the project's code, not a re-implementation:
//
//   LED library   what a perfect calibration run measures: the LedLab's true
//                 emission of each LED type alone at full drive, warmed up
//                 (true_leds.hpp; not the nominal library spectra);
//   mixes         calibration::solve_session_mix(library, "d65" | "w57" | "w57+blue",
//                 "camera"), what daemon::Calibrations::solved_mix gives a calibrated
//                 daemon;
//   light         the LedLab's true emission at those drive levels, junctions
//                 settled at that drive (so a 0.8 drive is not exactly 0.8 ×
//                 the full-drive spectrum: the lab's temperature drift);
//   scene         make_skin_scene (no white strip), one scene pixel per
//                 sensor site (the sensor sees the whole scene or a window
//                 of it), rendered in bands (render_skin_scene: the 5-MP albedo cube
//                 is never held whole); the white target scene for the white
//                 steps; truth maps at the sensor's resolution;
//   camera        CameraModel (nikon_d5100 sensitivities, 12-bit ADC, black
//                 level, shot and read noise, full well), Bayer RGGB, one
//                 BayerRG12 frame per step as the lab camera sends it; the
//                 exposure (all steps) puts the brightest white channel at
//                 white_fill of full scale, as an operator would set it;
//                 with exposure_per_capture each illumination's white is
//                 exposed to white_fill (the metered plan; W57 shares
//                 W57+blue's), and the dark keeps the single exposure;
//   noise-free    the same readout without noise (CameraModel::expected):
//                 BayerRG16 frames of the expected DN·16 (the lab camera's 16-bit
//                 encoding; steps of 1/16 DN);
//   captures      session::SessionCaptureBuilder (2×2 Bayer binning, illuminants from
//                 the library and the applied drive levels), then
//                 session::build_measurement (albedo against the white
//                 reference, the standard recipe's blue-only channel, registration, the noise
//                 estimated from the dark and white frames).
//
// The measurement is half the sensor's size per side (the binning). Truth
// per measurement pixel (one 2×2 sensor cell): the mean of the cell's scene
// parameters; region: the cell's region when its four sites agree, else
// kMixedCell. The noise-free measurement's set carries the noisy chain's
// noise estimate (its own frames have none to estimate: the estimator is
// told the camera's noise either way, as in the daemon).
//
// Thread rules: a pure function of its options (uses `threads` cores).

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "chromo/calibration/led_library.hpp"
#include "chromo/drivers/led_controller.hpp"
#include "chromo/session/method_measurement.hpp"
#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/simulators/scene/subject_motion.hpp"

namespace chromo::session {
class SessionCaptureBuilder;
}  // namespace chromo::session

namespace chromo::simulators {

struct RenderedSessionOptions {
  int sensor_width = 2592;   // even; 16-4096
  int sensor_height = 1944;  // even; 16-4096
  // The skin scene's size (0: the sensor's) and the sensor's window on it
  // (its top-left scene pixel): a tiny sensor can look at part of a 5-MP
  // scene, whose fields are as smooth per pixel as the bench's.
  int scene_width = 0, scene_height = 0;
  int window_x = 0, window_y = 0;
  std::uint64_t seed = 5;    // scene and camera noise
  // A built-in plan (session::builtin_plan): "standard" (the method's
  // session, everything as described above), "multispectral" or
  // "multispectral+method": their illumination states (the method's mixes
  // solved as above, the LED types alone at full drive), each step at its own
  // exposure (its state's brightest white channel at white_fill; the dark at
  // the longest), the captures through SessionCaptureBuilder::captures
  // and session::build_measurement (3 channels per capture: the plans' recipe).
  std::string plan = "standard";
  double white_fill = 0.85;  // expected DN of the brightest white channel / full scale
  // Exposure per capture (session_plan.hpp's standard plan with
  // meter_white_share = white_fill): the D65' and W57+blue whites each at
  // white_fill (W57 at W57+blue's exposure), each subject at its white's;
  // the dark at the single exposure. false: one exposure for every step, set
  // on the brightest white of the three (the plan before exposure metering).
  bool exposure_per_capture = false;
  double blue_ratio = 0;        // > 0: the mixes "w57+blue:R" and "w57:R" (0: "w57+blue", "w57")
  int frames_per_capture = 1;   // frames of every subject step, averaged by the capture builder (1-64)
  int reference_frames = 0;     // frames of the dark and white steps (0: frames_per_capture; 0-64)
  // Subject exposure metering (docs/daemon.md "Subject exposure";
  // the standard plan only; needs exposure_per_capture). > 0: each subject is
  // metered on a first frame of it at its white's exposure (its own noisy
  // frame, binned 2×2, frame index apart from the plan's):
  // session::meter_subject_exposure puts the subject_percentile of its
  // brightest channel at subject_fill of full scale, the ratio to the white's
  // exposure in [1, max_subject_exposure_ratio]; W57 takes W57+blue's ratio
  // (the blue-only difference at one exposure). Each white so scaled is
  // checked for linearity against the white at t_white / g
  // (IlluminatedCapture::white_linearity). The cache is not used.
  double subject_fill = 0;          // 0 (off) or (0.05, 0.99)
  double subject_percentile = 0.99;  // (0, 1]
  double max_subject_exposure_ratio = 8;  // [1, 64]
  // The lab camera's nonlinearity (CameraModelOptions::nonlinearity_at_full_well; 0: linear).
  double camera_nonlinearity = 0;
  bool noise_free = true;    // also render the noise-free chain
  // Keep the noisy chain's captures (RenderedSession::noisy_captures), so
  // that a bench can build the measurement again (registration options);
  // not kept when the session is loaded from the cache.
  bool keep_captures = false;
  int threads = 2;
  int band_rows = 128;       // scene rows rendered at a time
  // Cache (empty: none): cache_dir/rendered_session_<key>.bin holds the
  // rendered session (all but the measurements' photographs), keyed by a
  // hash of these options (not threads, band_rows), the mixes' camera
  // weights (true LED emission × camera sensitivity), the exposure, the
  // camera model's constants, a probe of the scene generator and skin model
  // (a 16×16 scene of this seed) and kRenderedSessionVersion (bump it when
  // the capture path — binning, session::build_measurement — or the
  // payload's encoding changes). A 5-MP session is 82 MB; the file is a
  // files/binary_cache.hpp cache (magic "CHRSESS1"), written durably; a
  // damaged file is re-rendered.
  std::filesystem::path cache_dir;
  // Subject motion between captures (subject_motion.hpp; off by default, so
  // the pinned figures of existing tests and benches stand). With motion on,
  // each subject capture is rendered at its pose at the moment of its
  // exposure on the plan's timeline: every step takes settle_ms + exposure +
  // readout_ms (one frame per step), from the dark on; the cache is not used.
  SubjectMotionOptions motion;
  std::uint32_t settle_ms = 50;   // the standard plan's LED settling per step, 0-60000
  double readout_ms = 43;         // frame readout (23 frames/s, NOTES.md), 0-10000
  // Polarisation (docs/polarisation.md, "Virtual lab physics"): the standard
  // plan polarised (session::standard_plan({.polarised = true}): the method
  // cross-polarised plus D65' parallel), every lit capture rendered through
  // render_polarised_skin with both films (PolariserFilm defaults but the
  // extinction ratio at 550 nm; its 400 nm value is min(20, that)) at the
  // design view (leak 0, sheen F(0°)); the LED library is the lab's through
  // both films (calibration::library_through_polariser with T_P·T_A: what a
  // per-state calibration through the camera's analyser measures), the mixes
  // solved on it. Plan "standard" only; the cache is not used.
  bool polarised = false;
  double extinction_ratio_550nm = 200;  // 1-100000
  // The estimator is given the films (Captures::surface_factors from
  // surface_factor_in_albedo at the design view): surface maps corrected for
  // the extinction, cross captures for their surface light. false: the
  // measurement as without that knowledge (the bench's "before" column).
  bool estimator_knows_films = true;
  // Oily regions on the skin (scene.hpp OilyHighlights: count, σ range,
  // roughness, radius); sigma_reflectance is set here to surface_sigma
  // (below). count 0: none.
  OilyHighlights oily;

  // The lab's imperfections, each switchable so bench/lab_floor_bench.cpp
  // can say what each costs; the defaults are the lab described above.
  // linear_led_light: every state's light is Σ drive · (the library's
  // full-drive spectrum per unit drive) over the LED types — exactly the
  // illuminant the capture builder tells the estimator — instead of the
  // LedLab's settled emission at those drives (junctions cooler at partial
  // drive: more flux per unit drive and a shifted peak).
  bool linear_led_light = false;
  // cell_uniform_scene: each 2×2 sensor cell (one measurement cell) sees one
  // scene pixel: the scene rendered at half the sensor's size per side
  // (scene_width/height and window_x/y halved; all must then be even), each
  // pixel filling a cell, so the cell's four Bayer sites see one albedo and
  // its truth is that pixel's parameters.
  bool cell_uniform_scene = false;
  // scene_anomalies false: SkinSceneOptions::anomalies = false (the skin
  // model's albedo under the vein, tattoo, marker, hair and highlight,
  // labelled as with them). Unpolarised only.
  bool scene_anomalies = true;
  // Subsurface spread in the photographs (scene.hpp SubsurfaceSpread,
  // subsurface_spread.hpp): each wavelength of the skin's albedo blurred by
  // σ(λ), from sigma_blue_px at ≤ 450 nm to sigma_red_px at ≥ 700 nm (scene
  // pixels), so edges and texture soften more in red than in blue; the truth
  // maps are the scene's parameters, unblurred. Off by default (the session
  // is then exactly the session without this option, cache key included).
  SubsurfaceSpread subsurface;

  bool IsValid(std::string* error) const;
};

// One moved subject capture and what the registration made of it.
struct CaptureMotion {
  std::string capture;               // "W57", "W57+blue"
  double seconds_since_reference = 0;  // after the D65' subject capture
  SubjectPose pose;                  // the truth (scene pixels, sensor grid)
  // |found − true| of the registration's map from the reference grid to
  // this capture's, in measurement pixels over a 9×9 grid spanning the image:
  // the largest and the RMS (0 when nothing moved and nothing was found).
  double registration_error_max_px = 0;
  double registration_error_rms_px = 0;
  double found_motion_px = 0;        // RegistrationReport::motion_px
};

// 2: the file is a files/binary_cache.hpp file (length and checksum).
// 3: the capture builder sums raw samples exactly and bins the mean
//    (session/frame_sums.hpp), which rounds the last bits differently.
// 4: exposure per capture, blue ratio and frames per capture (options and key).
// 5: any built-in plan (its name in the key), merged with 4.
// 6: the camera readout's band streams (CameraModel::expose): another
//    realisation of the same noise.
// 7: RegistrationResult::skipped_levels (coarse levels skipped).
// 8: RegistrationResult::method and translation_sigma_px (the fallback for
//    featureless captures).
// 9: ChannelNoise::white_coefficient (the noise model's white term, in a²).
// 10: a still subject decided on the coarse pyramid levels (RegistrationOptions::
//     decide_still_at_coarse_level): its residual_motion_px is the motion found.
// 11: RegistrationResult::photometric_outlier_share (the opt-in robust round).
// 12: the registration's tile consensus on by default (RegistrationOptions::
//     tile_consensus): a still capture keeps the identity more often.
inline constexpr std::uint32_t kRenderedSessionVersion = 12;
inline constexpr std::uint8_t kMixedCell = 255;  // a 2×2 cell whose sites have different regions

struct RenderedSession {
  int width = 0, height = 0;                       // the measurement's (sensor / 2)
  session::Measurement noisy, noise_free;  // noise_free empty unless options.noise_free
  std::vector<estimation::SkinParameters> truth;   // per measurement pixel
  std::vector<std::uint8_t> region;                // SceneRegion per pixel, or kMixedCell
  calibration::LedLibrary library;
  std::map<std::string, drivers::DriveLevels> mixes;  // per state: "d65", "w57", "w57+blue" (keys without ":R"); "W57" ... "B" (alone)
  double exposure_us = 0;  // the single exposure: the brightest state's white at white_fill (every step's in the standard plan unless exposure_per_capture)
  std::map<std::string, double> exposure_us_of_step;  // each step of the plan
  std::map<std::string, session::SubjectMeteringResult> subject_metering;  // per subject step (subject_fill > 0)
  std::map<std::string, std::array<double, 3>> white_response;  // CameraModel response of the white target per state
  double scene_seconds = 0, camera_seconds = 0, measurement_seconds = 0;  // wall clock per stage (of the render)
  bool loaded_from_cache = false;
  std::vector<CaptureMotion> motion;  // the noisy chain's W57 and W57+blue captures (empty when loaded from the cache)
  double plan_seconds = 0;            // the plan's timeline, first step to the end of the last
  // σ of the surface map (parallel − cross)/2 in albedo units, green, at the
  // scene's mean skin green albedo, from the camera model (shot, read and
  // the white reference's noise; 2×2 binning): the unit of the oily
  // regions' strengths. 0 unless polarised.
  double surface_sigma = 0;
  double sheen = 0;                   // F(0°) of the design view (polarised), else 0
  std::shared_ptr<const session::SessionCaptureBuilder> noisy_captures;  // options.keep_captures, else null
  std::size_t pixels() const { return truth.size(); }
};

// The LED library a perfect calibration run measures in the virtual lab:
// each LED type's true emission alone at full drive, warmed up (LedLab,
// true_leds.hpp), in SphereIllumination units — the units the camera model's
// quantum scale is given in, so exposures computed from it are the lab's.
// render_session's library (source "measured").
calibration::LedLibrary lab_led_library();

// Throws std::invalid_argument for bad options (naming the field).
RenderedSession render_session(const RenderedSessionOptions& options);

// Each measurement cell's added surface reflection (make_skin_scene's
// highlight, skin_scene_added_reflection, plus the oily regions of
// options.oily with the σ of `surface_sigma`, skin_scene_oily_reflection): the mean over the
// cell's 2×2 sensor sites, at the scene pixels `options` put them on (scene
// size and window). Truth for the specular shares per band of reflection.
std::vector<float> cell_added_reflection(const RenderedSessionOptions& options, double surface_sigma = 0);

}  // namespace chromo::simulators
