#pragma once
// The skin scene as a polarised sphere's camera sees it (docs/polarisation.md,
// "Virtual lab physics"): the scene's diffuse albedo (depolarised) plus its
// surface layer — the Fresnel sheen F(θ) everywhere on the skin (η = 1.4,
// exact Fresnel, θ the camera's angle from the patch normal) and the oily
// highlight of make_skin_scene (skin_scene_added_reflection, flat) — through
// the light bank's polariser and the camera's analyser.
//
// An unpolarised sphere keeps the old path: render_polarised_skin with no
// sphere is Scene::render, bit for bit (the scene's albedo already holds its
// highlight, and the sheen is what the diffusion model's overestimate absorbs,
// MODEL.md).

#include <opencv2/core.hpp>

#include <optional>
#include <vector>

#include "chromo/drivers/led_controller.hpp"
#include "chromo/simulators/polarisation/polariser_optics.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::simulators {

struct PolarisedSphere {
  PolariserFilm light_film;      // in front of the LED banks
  PolariserFilm analyser_film;   // on the camera lens
  double view_angle_deg = 0;     // the camera's angle from the patch normal (the sheen's F(θ))
  double cross_leak = 0;         // cross_polarisation_leak(...).lobe_leak of this view; 0 at the design view
  // true: the weights come from light that already passed the light film
  // (the LED lab's emission includes T_P, and 2·T_P for both banks), so the
  // render applies only the analyser's transmission T_A and the state's
  // surface factor: Σ weights·T_A·(diffuse + c_state·surface). The light
  // film then only sets c_state. The camera simulators render this way.
  bool light_film_in_illumination = false;
};

// The surface layer of make_skin_scene(options)'s pixels (its window):
// CV_32F, height × width, a flat reflectance: F(θ) + the highlight on every
// pixel but the white target (a depolarising target has none).
cv::Mat skin_surface_layer(const Scene& scene, const SkinSceneOptions& options, double view_angle_deg);

// Σ_λ weights(c, λ)·T_P(λ)T_A(λ)·(diffuse(λ) + c_state(λ)·surface) per pixel
// (CV_32FC(n) like Scene::render), where diffuse is the scene's albedo
// without its highlight; on the white target Σ weights·T_P·T_A·ρ_white.
// Dividing by the white reference of the same state removes T_P·T_A.
// With sphere->light_film_in_illumination the films' factor is T_A alone.
// `scene` must be make_skin_scene(options). Without a sphere: Scene::render.
cv::Mat render_polarised_skin(const Scene& scene, const SkinSceneOptions& options, const SceneWeights& weights,
                              drivers::Polarisation state, const std::optional<PolarisedSphere>& sphere);

// render_skin_scene (scene.hpp) for a polarised sphere: make_skin_scene(options)
// in bands of band_rows rows, each band's response under weights[k] in
// states[k] (render_polarised_skin), plus the regions and truth maps.
// Without a sphere: render_skin_scene. Throws std::invalid_argument for bad
// options, band_rows < 1, or states of another size than weights.
SkinSceneResponse render_polarised_skin_scene(const SkinSceneOptions& options, const std::vector<SceneWeights>& weights,
                                              const std::vector<drivers::Polarisation>& states,
                                              const std::optional<PolarisedSphere>& sphere, int band_rows = 128);

}  // namespace chromo::simulators
