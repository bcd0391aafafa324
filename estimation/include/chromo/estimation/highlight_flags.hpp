#pragma once
// The optical highlight flag (docs/polarisation.md, "Estimation outputs";
// docs/estimation.md): where a polarised session's surface map S (the
// surface layer in albedo units, session::Measurement::surface)
// exceeds the skin's own Fresnel sheen by more than its noise allows.
//
// An INFORMATION flag: it changes no parameter and no pixel flag. The
// diffuse maps there still come from the cross-polarised captures (which
// block all but 4/ER of the surface reflection).
//
// Sheen reference F_ref: the median of S over the finite pixels, capped at
// F(θ) = kSheenAtNormal (the exact Fresnel reflectance at η = 1.4, 0.02778)
// — the measured sheen already carries the films' extinction shortfall
// ((ER − 1)²/(ER + 1)², 0.98 at 1:200) and a view's leak, and the cap keeps
// a face that is oily over most of its pixels from raising its own
// reference. With z_i = (S_i − F_ref)/σ_i (σ_i: Measurement::surface_sigma),
// a pixel is flagged when
//   z_i ≥ pixel_sigmas (2)   and   Σ_j (S_j − F_ref) / √(Σ_j σ_j²) ≥ window_sigmas (3)
// over its 3×3 window's finite pixels: the window's evidence keeps lone
// noise out (on sheen-only skin ~0.02% flagged), the pixel's own test keeps
// the window from spreading a highlight onto the skin around it (≤ 2.3% of
// a one-pixel rim). A highlight of 4σ is flagged ≈ 97.7% of the time.
//
// Thread rules: a pure function.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace chromo::estimation {

inline constexpr double kSheenAtNormal = 0.02778;  // ((1.4 − 1)/(1.4 + 1))²

struct HighlightFlagOptions {
  double pixel_sigmas = 2;
  double window_sigmas = 3;
  double sheen_cap = kSheenAtNormal;
};

struct HighlightFlags {
  std::vector<std::uint8_t> flag;  // 1 highlight, 0 not (or no surface value)
  double sheen_reference = 0;      // F_ref
  std::size_t flagged = 0;
};

// surface and sigma: width × height, row-major (NaN where not measured).
// Throws std::invalid_argument for sizes that do not match or options
// that are not positive.
HighlightFlags flag_highlights(std::span<const float> surface, std::span<const float> sigma, int width, int height,
                               const HighlightFlagOptions& options = {});

}  // namespace chromo::estimation
