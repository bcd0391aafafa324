#pragma once
// Subsurface spread in the virtual lab's skin scene (issue 37): light that
// enters skin at one point leaves it at another, more in the red than in the
// blue, so a photograph sees the skin's albedo blurred, a wavelength at a
// time. With SkinSceneOptions::subsurface on, make_skin_scene blurs each
// wavelength's albedo image with a Gaussian of σ(λ) scene pixels:
//   σ(λ) = sigma_blue_px at ≤ 450 nm, rising linearly to sigma_red_px at ≥ 700 nm
// (defaults 0.5 and 3 px: at 0.1 mm a pixel, the 0.05-0.3 mm diffusion
// lengths 1/σtr of MODEL.md's dermis between blue and red). A documented
// assumption of the lab, not the two-layer model's radial profile
// (`chromo profiles`) and not a measured point spread function.
// What leaves at the surface is not spread: a pixel's surface reflection
// (the highlight) is taken out before the blur and added back, and the white
// target neither spreads nor receives light (the blur is normalised over the
// skin side only).
//
// Thread rules: pure functions.

#include <functional>
#include <string>

#include <opencv2/core.hpp>

#include "chromo/simulators/scene/scene.hpp"

namespace chromo::simulators {

// SubsurfaceSpread (the option) is declared in scene.hpp, beside SkinSceneOptions.


// Spreads `scene`'s albedo in place as the header says: `skin_side` (CV_8U,
// the scene's size, non-zero where light enters skin: not the white target)
// selects the pixels that spread and receive, `surface(x, y)` is the flat
// surface reflection of scene pixel (x, y) (albedo units). Pixels outside
// skin_side are unchanged. Throws std::invalid_argument for an invalid
// `spread` or a mask of another size.
void apply_subsurface_spread(Scene& scene, const SubsurfaceSpread& spread, const cv::Mat& skin_side,
                             const std::function<double(int, int)>& surface);

}  // namespace chromo::simulators
