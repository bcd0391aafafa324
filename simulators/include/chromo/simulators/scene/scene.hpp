#pragma once
// Scene: what the virtual lab's camera looks at, as ground truth.
//
// A scene is a grid of pixels, each with a diffuse albedo spectrum on the
// project grid (stored as float, width·height·81), a region label and the
// skin parameters (Cm, Ch, βm, Che) it was built from. Skin albedo comes
// directly from estimation::SkinModel (albedo_batch, all cores), never from an
// estimator's table; the regions the model cannot (or only partly) explain
// modify that albedo as documented in make_skin_scene() and docs/camera.md.
//
// Resolution: scenes are kept modest (default 512×512, 85 MB of float
// spectra); the camera simulator renders the response at scene resolution and
// resamples it (bilinear) to the sensor. Immutable after construction, safe to
// share between threads.

#include <opencv2/core.hpp>

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "chromo/spectral/spectrum.hpp"

namespace chromo::simulators {

// Region labels (CV_8U values in Scene::regions()). Everything but kSkin and
// kWhiteTarget is something the skin model cannot, or only partly, explain.
enum class SceneRegion : std::uint8_t {
  kSkin = 0,
  kVein = 1,         // deeper deoxygenated blood: partly explainable (Ch rises, plus an extra deoxy term)
  kTattoo = 2,       // ink reflectance mixed in: not explainable
  kMarker = 3,       // a dye stroke on the surface (double-pass transmission): not explainable
  kHair = 4,         // dark strands over the skin: not explainable
  kSpecular = 5,     // surface reflection added (flat spectrum): not explainable
  kWhiteTarget = 6,  // the white reference target, reflectance white_target_reflectance()
};
const char* region_name(SceneRegion region);

// The white reference target's known reflectance ρ_white: flat 0.99 (a
// sintered-PTFE target is flat within about ±1% over 400-780 nm).
inline constexpr double kWhiteTargetReflectance = 0.99;
spectral::Spectrum white_target_reflectance();

class Scene {
 public:
  Scene(int width, int height);

  int width() const { return width_; }
  int height() const { return height_; }

  spectral::Spectrum albedo_at(int x, int y) const;
  void set_albedo(int x, int y, const spectral::Spectrum& albedo);
  const float* albedo_data() const { return albedo_.data(); }  // row-major pixels, 81 floats each

  // CV_8U labels (SceneRegion values) and CV_32F truth maps of the skin parameters
  // underneath every pixel (also under tattoos, hair... where they are not observable).
  cv::Mat& regions() { return regions_; }
  const cv::Mat& regions() const { return regions_; }
  cv::Mat& cm() { return cm_; }
  const cv::Mat& cm() const { return cm_; }
  cv::Mat& ch() { return ch_; }
  const cv::Mat& ch() const { return ch_; }
  cv::Mat& bm() { return bm_; }
  const cv::Mat& bm() const { return bm_; }
  cv::Mat& che() { return che_; }
  const cv::Mat& che() const { return che_; }

  // Σ_λ weights(c, λ)·albedo(λ) for every pixel: CV_32FC(n) at scene
  // resolution, n = weights.rows() (1-4). The camera model supplies the weights.
  cv::Mat render(const Eigen::Matrix<double, Eigen::Dynamic, spectral::kGridSize>& weights) const;

 private:
  int width_, height_;
  std::vector<float> albedo_;
  cv::Mat regions_, cm_, ch_, bm_, che_;
};

// Oily regions (docs/polarisation.md, "Oily highlights"): `count` domes of
// oil film, each adding a flat surface reflection of peak
// strength_k = n_k · sigma_reflectance, n_k spaced logarithmically from
// min_sigma to max_sigma over the regions (in σ of the polarised capture's
// surface map, (parallel − cross)/2, which the caller computes from its
// camera's noise model), shaped by a roughness-dependent lobe over the
// sphere's lit directions (skin_scene_oily_reflection). count = 0 (the
// default): none, and the scene is exactly the scene without this option.
struct OilyHighlights {
  int count = 0;                    // 0-64
  double sigma_reflectance = 0;     // reflectance of one σ (> 0 when count > 0)
  double min_sigma = 1, max_sigma = 20;
  double min_roughness_rad = 0.05, max_roughness_rad = 0.35;  // per region, seeded
  double min_radius_px = 10, max_radius_px = 22;              // at 512 px width, scaled with it
};

// Subsurface spread of the skin scene (subsurface_spread.hpp says what it does).
struct SubsurfaceSpread {
  bool on = false;              // off: the scene is exactly the scene without this option
  double sigma_blue_px = 0.5;   // σ at ≤ 450 nm, scene pixels
  double sigma_red_px = 3.0;    // σ at ≥ 700 nm, scene pixels
  // σ(λ) in scene pixels, as the header says.
  double sigma_px(double wavelength_nm) const;
  // 0 < sigma_blue_px ≤ sigma_red_px ≤ 64; names the field otherwise.
  bool IsValid(std::string* error) const;
};

struct SkinSceneOptions {
  int width = 512;
  int height = 512;
  std::uint64_t seed = 1;
  bool white_patch = true;  // a white target strip along the right edge (1/10 of the width)
  int threads = 0;          // for SkinModel::albedo_batch and the per-pixel loops; 0 = all cores
  // A window of the scene: rows [row_begin, row_begin + row_count) and
  // columns [column_begin, column_begin + column_count) of the width × height
  // scene (same fields, moles, vein... as the whole scene; the window's pixel
  // (0, 0) is the scene's (column_begin, row_begin)). A count of 0: all.
  int row_begin = 0;
  int row_count = 0;
  int column_begin = 0;
  int column_count = 0;
  OilyHighlights oily;
  // The scene's one highlight (skin_scene_added_reflection). false: none
  // (the labels of what lies under it, for benches scoring the skin there).
  bool highlight = true;
  // false: every pixel but the white target keeps the skin model's albedo
  // (no vein, tattoo, marker, hair or highlight in the light), the regions
  // labelled as with them: what the skin cells' measurement would be with
  // nothing of those leaking into them (bench/lab_floor_bench.cpp).
  bool anomalies = true;
  // A change of the subject between two sessions (issue 42's before/after):
  // Ch multiplied by ch_factor inside the rectangle [ch_change_x,
  // ch_change_x + ch_change_width) × [ch_change_y, ch_change_y +
  // ch_change_height) of the full scene's pixels. 1 (the default): none, and
  // the scene is exactly the scene without this option.
  double ch_factor = 1;
  int ch_change_x = 0, ch_change_y = 0, ch_change_width = 0, ch_change_height = 0;
  // Subsurface spread (subsurface_spread.hpp): each wavelength blurred by
  // σ(λ), wider in the red; off by default.
  SubsurfaceSpread subsurface;

  bool IsValid(std::string* error) const;
};

// A forearm-like skin patch: smooth Cm, Ch, βm, Che fields (seeded), a few
// moles (high Cm, explainable), a vein, a tattoo, a marker stroke, hair, a
// specular highlight and (optionally) the white target strip.
Scene make_skin_scene(const SkinSceneOptions& options);

// The flat surface reflection make_skin_scene adds at scene pixel (x, y) of a
// width × height scene: its highlight, 0.3·exp(−r²) on an ellipse at (0.65 w,
// 0.2 h) with radii 0.08 w and 0.04 h, labelled kSpecular where ≥ 0.006
// (truth for reporting flagged shares by strength).
double skin_scene_added_reflection(int width, int height, double x, double y);

// The oily regions' added reflection at scene pixel (x, y) of the
// options' width × height scene (0 without oily regions). Region k is a
// dome of radius R_k whose surface normal tilts by t(r) = 40°·r/R_k at
// distance r from its centre; the design camera's mirror direction is then
// 2t(r) from the patch normal, and a facet-tilt lobe of standard deviation
// roughness_k spreads it over 2·roughness_k. The sphere lights directions up
// to 70° from the patch normal, so the lobe's lit share is
// Φ((70° − 2t)/(2·roughness_k)) (one-dimensional along the tilt), relative to
// its value at the dome's top; the oil film covers r < R_k, fading over the
// last 20% of the radius. reflection = strength_k · coverage · lit share
// (regions add).
double skin_scene_oily_reflection(const SkinSceneOptions& options, double x, double y);

// Everything make_skin_scene(options) adds as a flat surface reflection at
// scene pixel (x, y): the highlight where it exceeds 0.006 plus the oily
// regions; the pixel is labelled kSpecular where this is > 0 (unless a
// later region — the white target — covers it).
double skin_scene_surface_highlight(const SkinSceneOptions& options, double x, double y);

// The share of scene pixel (x, y) the marker stroke's dye covers: 1 within
// 4·width/512 px of the stroke from (0.5 w, 0.85 h) to (0.85 w, 0.6 h),
// falling to 0 over the next pixel; labelled kMarker where > 0 (truth for
// reporting flagged shares by cover).
double skin_scene_marker_cover(int width, int height, double x, double y);

// make_skin_scene(options)'s response under each of `weights` (Scene::render)
// and its region labels and truth maps (of options' window), rendered band by
// band (band_rows rows at a time) so that the albedo cube is never held
// whole: a 2592×1944 scene's is 1.6 GB of floats, a band of 128 rows 107 MB.
// Identical to make_skin_scene(options).render(w) for every w (the bands are
// the same scene's rows). Throws std::invalid_argument for bad options or
// band_rows < 1.
struct SkinSceneResponse {
  std::vector<cv::Mat> responses;  // CV_32FC(weights[k].rows()) each, height × width
  cv::Mat regions, cm, ch, bm, che;
};
using SceneWeights = Eigen::Matrix<double, Eigen::Dynamic, spectral::kGridSize>;
SkinSceneResponse render_skin_scene(const SkinSceneOptions& options, const std::vector<SceneWeights>& weights,
                                    int band_rows = 128);

// The banding of render_skin_scene with any renderer: response k of a band
// is render(band's scene, band's options, k), CV_32FC(channels[k]).
using BandRender = std::function<cv::Mat(const Scene& band, const SkinSceneOptions& band_options, std::size_t k)>;
SkinSceneResponse render_skin_scene_bands(const SkinSceneOptions& options, const std::vector<int>& channels, int band_rows,
                                          const BandRender& render);

// A scene that is all white target (for white-reference captures).
Scene make_white_target_scene(int width, int height);

}  // namespace chromo::simulators
