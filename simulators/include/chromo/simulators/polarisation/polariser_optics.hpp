#pragma once
// Linear polarisers of the virtual lab (the sphere's light banks and the
// cameras' analysers) and what a polarised capture sees of skin's two layers
// (docs/polarisation.md, "Virtual lab physics").
//
// A polariser film has two principal transmittances per wavelength: k1 along
// its axis and k2 across it; its extinction ratio is k1/k2 and its
// transmission of unpolarised light (k1 + k2)/2. Films are weaker in the
// blue: the extinction ratio falls log-linearly from its 550 nm value to its
// 400 nm value (and keeps falling below 400 nm, stays flat above 550 nm);
// the transmission is interpolated linearly between its 400 nm and 550 nm
// values the same way.
//
// Capture model, per wavelength, for a light bank with film P and a camera
// analyser A (the same film by default), the light's polarisation reaching
// the analyser at leak f from its blocked axis (cross_polarisation_leak:
// 0 at the design view):
//   subsurface (depolarised) light d:   T_P · T_A · d                (either state)
//   surface (polarisation-keeping) s:   cross:    ½[k1P·(k2A(1−f) + k1A f) + k2P·(k1A(1−f) + k2A f)] · s
//                                        parallel: ½[k1P·(k1A(1−f) + k2A f) + k2P·(k2A(1−f) + k1A f)] · s
// with T = (k1 + k2)/2. A white reference (a depolarising target) captured in
// the same state divides by T_P·T_A, so in albedo units a capture is
// d + c·s with c = surface factor / (T_P·T_A): about 4/ER for cross and 2 for
// parallel. An unpolarised sphere (no films) sees d + s.

#include <string>

#include "chromo/drivers/led_controller.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::simulators {

struct PolariserFilm {
  double extinction_ratio_550nm = 200;  // k1/k2 at 550 nm (1:200)
  double extinction_ratio_400nm = 20;   // weaker in the blue
  double transmission_550nm = 0.42;     // of unpolarised light, (k1 + k2)/2
  double transmission_400nm = 0.30;

  bool IsValid(std::string* error) const;  // ratios ≥ 1, transmissions in (0, 0.5]
  double extinction_ratio_at(double wavelength_nm) const;
  double transmission_at(double wavelength_nm) const;
  // (k1 + k2)/2, the transmission of unpolarised light, on the project grid.
  spectral::Spectrum transmission() const;
  // k1 and k2 on the project grid.
  spectral::Spectrum axis_transmittance() const;
  spectral::Spectrum cross_transmittance() const;
};

// What a capture sees, in albedo units after its own white reference, of a
// surface reflection of 1: the c of "d + c·s" above, on the project grid.
// kUnpolarised on a polarised sphere drives both banks: the mean of the cross
// and the parallel factors. Throws std::invalid_argument for an invalid film
// or a leak outside [0, 1].
spectral::Spectrum surface_factor_in_albedo(drivers::Polarisation state, const PolariserFilm& light_film,
                                            const PolariserFilm& analyser_film, double leak);

// T_P · T_A: the share of subsurface light a polarised capture keeps (any
// state), removed again by the white reference of the same state.
spectral::Spectrum diffuse_transmission(const PolariserFilm& light_film, const PolariserFilm& analyser_film);

}  // namespace chromo::simulators
