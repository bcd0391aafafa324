#pragma once
// Layer optics of MODEL.md: total diffuse reflectance and transmittance at
// zero spatial frequency. Scalar versions for one wavelength; SkinModel uses
// the same algebra vectorised over the grid.
//
// Per layer: σt' = σa + σs', α' = σs'/σt', σtr = sqrt(3 σa σt'), D = 1/(3σt'),
// l = 1/σt', extrapolation distance z_b = 2·A·D.

namespace chromo::estimation {

// Fdr(η) = -1.440/η² + 0.710/η + 0.668 + 0.0636·η
double diffuse_fresnel_reflectance(double eta);
// A = (1 + Fdr)/(1 - Fdr); about 3.25 at η = 1.4. Index-matched boundaries
// use A = 1 by definition (kIndexMatchedA), never this function at η = 1.
double boundary_coefficient(double eta);
inline constexpr double kIndexMatchedA = 1.0;

struct SlabReflectance {
  double reflectance = 0;    // R
  double transmittance = 0;  // T
};

// Multipole slab of thickness d_mm, light entering through the boundary with
// coefficient a_entry (z_b0) and leaving through a_exit (z_bd).
//
// multipole_slab evaluates the infinite pole sum exactly: along each of the
// four families z_i = 2i(d + z_b0 + z_bd) + c the terms sgn(z_i)·e^(-σtr|z_i|)
// form two geometric series (one each side of the sign change), so the sum
// needs two exponentials per family whatever the number of poles.
SlabReflectance multipole_slab(double sigma_a_per_mm, double sigma_s_reduced_per_mm, double d_mm, double a_entry,
                               double a_exit);

// The same sum written out term by term for i = -N..N, N growing until the
// last pair changes R and T by less than tolerance (MODEL.md: 1e-9). Reports
// the N used. For tests and for anyone checking the closed form.
SlabReflectance multipole_slab_explicit(double sigma_a_per_mm, double sigma_s_reduced_per_mm, double d_mm,
                                        double a_entry, double a_exit, double tolerance = 1e-9,
                                        int* pole_pairs_used = nullptr);

// Semi-infinite dipole with an index-matched top (A = a_top):
// R2 = (α'/2)·(1 + exp(-(4/3)·A·sqrt(3(1-α'))))·exp(-sqrt(3(1-α'))).
double dipole_semi_infinite(double sigma_a_per_mm, double sigma_s_reduced_per_mm, double a_top = kIndexMatchedA);

// Donner & Jensen 2005 at zero frequency, one R1/T1 used both ways:
// albedo = R1 + T1·R2·T1 / (1 - R1·R2).
inline double combine_two_layers(double r1, double t1, double r2) { return r1 + t1 * r2 * t1 / (1.0 - r1 * r2); }

}  // namespace chromo::estimation
