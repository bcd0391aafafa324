#pragma once
// The sphere's light-side polariser pattern and how well it crosses each
// camera view (docs/polarisation.md, "Geometry").
//
// The pattern is designed for one view (the design camera): the linear
// polariser in front of each light is oriented so that the light's mirror
// reflection toward the design camera is polarised at right angles to that
// camera's analyser (its transmission axis is the camera's image x axis).
// Another camera sees each light's mirror reflection through a different
// surface orientation, so the reflected polarisation is no longer exactly
// at right angles to its analyser; a fraction leaks through the cross state.
//
// Geometric model: the specular reflection of light from direction l toward
// direction v happens on facets with normal h = (l + v)/|l + v| and maps the
// light's polarisation vector e to e − 2(e·h)h (the mirror image; Fresnel's
// r_s ≠ r_p rotation is left out). The leak of one light is (R_h(e)·a)² for
// the camera's analyser direction a. Lights: `light_count` directions spread
// evenly (Fibonacci) over the hemisphere facing the patch. Directions are
// unit vectors from the patch centre, in the camera_view.hpp world frame.

#include <opencv2/core.hpp>

namespace chromo::simulators {

struct CrossPolarisationLeak {
  // The analyser angle (from the camera's image x axis, degrees, in [0, 180))
  // that minimises lobe_leak: the camera's analyser is set there once.
  double analyser_angle_deg = 0;
  // Fraction of the polarisation-keeping (surface) reflection that passes the
  // cross state, for the light at the flat patch's mirror direction of the camera.
  double mirror_leak = 0;
  // The same, averaged over the lights weighted by a Gaussian lobe of facet
  // tilt (angle between h and the patch normal, standard deviation roughness_rad).
  double lobe_leak = 0;
};

// design_view and camera_view: directions from the patch centre to the two
// cameras (unit or not); roll_deg of the camera about its optical axis (the
// analyser turns with it). Throws std::invalid_argument for a view behind the
// patch (z ≥ 0), roughness_rad ≤ 0 or light_count < 100.
CrossPolarisationLeak cross_polarisation_leak(const cv::Vec3d& design_view, const cv::Vec3d& camera_view,
                                              double roughness_rad, double camera_roll_deg = 0,
                                              int light_count = 4000);

}  // namespace chromo::simulators
