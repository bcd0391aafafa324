#pragma once
// Second, spatial pass of the estimator: decisions one pixel cannot make.
//
// One pixel is ambiguous: tattoo ink over light skin at low coverage looks like
// more melanin, a weak surface reflection looks like paler skin, and a pixel of
// a 4D-model region whose βm/Che effect is below its own noise passes the 2D
// test. Skin varies smoothly (Cm, βm, Che over centimetres; only moles and
// vessels change faster), so a pixel is judged against its neighbourhood:
//
// Flags (refine_flags_with_neighbourhood), PixelFlag::kNeighbourhood:
//  1. Background: for every pixel, the skin its neighbours predict: per
//     channel a local quadratic fit (normalised convolution of order 2,
//     Gaussian σ = background_sigma_px) of the measured values of explained,
//     non-deviating pixels at least exclusion_px away from any flagged pixel
//     (a flagged region's weak rim must not serve as its own background).
//  2. Deviation: z_c = (measured − background)/σ_c (camera noise plus
//     background_sigma_relative·albedo, 0 by default), averaged with
//     Gaussian weights g (σ = deviation_sigma_px) over the neighbours of the
//     same class (deviating or not, so neither bleeds into the other), scaled
//     to unit variance under noise alone: u_c = z̄_c·Σg/√Σg². The statistic
//     is measured against the noise plus the skin's own misfit around its
//     background (fields finer than the background window, or less noise at
//     a longer exposure): E = the local second moments ⟨u uᵀ⟩ of the
//     background's source pixels over misfit_sigma_px (on 4-px blocks),
//     floored at the identity (camera noise alone; blocks whose diagonal
//     stays within misfit_ratio use the identity), and T = uᵀ E⁻¹ u, χ² with
//     C degrees of freedom for skin at any scale or exposure. T above its
//     (1 − significance) quantile makes a pixel deviating (1 −
//     rim_significance next to a flagged pixel: a hysteresis, as an edge
//     detector lowers its threshold next to a known edge).
//     The deviating set is iterated (it leaves the background) until it
//     settles.
//  3. 8-connected regions of deviating pixels that touch a flagged pixel
//     (first pass or this one) are flagged: the weak rim of a tattoo or a
//     marker stroke, the part of a highlight that looks like paler skin.
//     Deviating regions that touch nothing stay explained: a mole or a
//     vessel's explainable part deviates from its surroundings too, and one
//     region's mean cannot tell a surface reflection from a Cm/Ch change
//     (tried: a Cm/Ch jump test passed highlights and failed a mole).
//  4. Reflections grow (grow_reflections), in rounds where no deviating
//     region joined: a one-sided test of a white
//     surface reflection, the matched filter w = aᵀE⁻¹u/√(aᵀE⁻¹a) along
//     a_c = 1/σ_c (what an added flat s does to u) against the same noise
//     plus misfit, above its 1 − reflection_significance quantile; 8-connected
//     regions of such pixels that touch a specular or saturated pixel (or one
//     so joined) are flagged: the highlight's rim grows ring by ring.
//     4b. Partial covers join in the same rounds (grow_mixtures): a pixel
//     beside material flagged before the pass (not a reflection: ink, dye,
//     hair) that is partly covered by it moves from its background by
//     cover × (material − background). The same one-sided matched test,
//     along d_c = (mean of the flagged neighbours' values − background)/σ_c,
//     above its 1 − mixture_significance quantile, joins it: the stroke's
//     or the disk's antialiased edge, one ring wide (the test's direction
//     comes only from pixels flagged before the pass, so it does not grow).
//  5. Repeated until nothing joins: deviating regions in the first
//     max_passes rounds, reflections and partial covers for
//     max_growth_passes more.
//  6. Holes: explained regions of at most max_hole_px enclosed by flagged
//     pixels (not reaching the image border) are flagged.
//
// Scale. The windows (background_sigma_px, exclusion_px, misfit_sigma_px,
// deviation_sigma_px, max_hole_px) were tuned on the lab's scene rendered at
// 128-512 px across, and they stand for sizes on the skin (the skin's fields,
// a highlight, a vessel). The lab's camera always frames the same field (the
// sphere's port), so an image's size says its pixel pitch: an image whose
// longer side exceeds 2 × reference_width_px (256) is first averaged in
// blocks of block_px × block_px cells, block_px = round(longer side / 256)
// (5 for the 5-MP session's 1296×972 cells), and steps 1-6 run on that level
// with each block's mean of its explained cells (noise σ/√cells; a block is
// flagged when most of its cells are, a seed when ≥ 20% are, a reflection
// seed when those are mostly specular or saturated). Back on the cells: a
// block joined by step 3, or any joined or enclosed block with an open
// neighbour, flags only its explained cells that deviate on their own from
// the background it was judged against (interpolated between blocks) — the
// χ² test at the rim significance with one cell's noise, or for reflection
// blocks also the white test; a block joined by step 4 away from the edge,
// or enclosed, flags all of its cells. A sensor window or another field of
// view sets block_px itself (0: from the size).
//
//  Limits (docs/estimation.md, measured on the virtual lab's scene at 128-512
//  px and 0.5-2.5× exposure: skin ≤ 0.88% flagged; the 5-MP session 0.14%): a
//  marker edge pixel with less than 10-20% dye is not told from skin (marker
//  88-98% flagged, ≥ 97% of its pixels with ≥ 20% dye); an
//  undetected part of a highlight raises the local misfit E and the quadratic
//  background follows a smooth bump wider than its window, so the rim growth
//  stops short of the label's edge (specular 23-75% on the grid, 70-76% at 5 MP);
//  the vein counts as skin misfit (0-7.3% flagged); skin next to a flagged
//  region that deviates for its own reasons (a mole) joins it.
//
// Model order (pool_model_order): the likelihood-ratio statistic χ²₂ − χ²₄ of
// the explained pixels is summed over a square window of order_window_px;
// under the 2D model the sum of N pixels' statistics is χ² with 2N degrees of
// freedom (independent noise), so the window test keeps the single pixel
// test's significance while the 4D effect of a region adds up N times.
// A pixel whose window decides 4 but that chose 2 is refitted in 4D; one whose
// window decides 2 but chose 4 is refitted in 2D unless its own 2D fit is not
// explained (then it stays 4). The refits run on the estimator's threads
// (EstimatorOptions::threads, 0 = all cores); the result does not depend on
// their number. Given `other` (the first pass's OtherOrderFit per pixel, for
// the same measured values), a pixel whose stored fit is of the decided order
// takes it (Estimator::estimate_from_fit) instead of a refit: the same
// estimates bit for bit, without a second inversion.
//
// Cost (CPU, shared machine): 1.4-1.9 s at 256 px, 7.3-7.7 s at 512 px
// (block 1); the 5-MP session 1.7 s on 260×195 blocks (was 19-25 s on its
// cells).
//
// Thread rules: free functions over caller-owned buffers; reentrant. They use
// OpenCV (single call, OpenCV's own threads) and, for the pooled order's
// refits, OpenMP on the estimator's threads.

#include <span>
#include <string>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/local_bias.hpp"

namespace chromo::estimation {

struct NeighbourhoodOptions {
  double background_sigma_px = 6;
  int exclusion_px = 6;                      // the background ignores pixels this close to a flagged one
  double deviation_sigma_px = 0.7;
  double background_sigma_relative = 0.0;    // extra background error, relative to albedo (E measures the misfit)
  double misfit_sigma_px = 12;               // window of the skin's measured scatter around its background
  double misfit_ratio = 1.1;                 // scatter up to this × the noise counts as noise alone
  double significance = 1e-5;                // per pixel test of the averaged deviation
  double rim_significance = 1e-3;            // the same for pixels next to a flagged one (hysteresis)
  double reflection_significance = 1e-3;     // one-sided white test of a highlight's rim (grow_reflections)
  bool grow_reflections = true;
  bool grow_mixtures = true;                 // step 4b: partial covers beside flagged material
  double mixture_significance = 1e-3;        // its one-sided test along the material's deviation (as the white test)
  int max_passes = 20;                       // rounds in which deviating regions join
  int max_growth_passes = 20;                // further rounds in which only reflections grow
  int max_hole_px = 1024;  // explained regions enclosed by flagged pixels up to this size are flagged
  int order_window_px = 7;
  // The level the flag pass runs on (see "Scale" above): blocks of block_px ×
  // block_px cells, or, when block_px is 0, 1 up to a longer side of 2 ×
  // reference_width_px and round(longer side / reference_width_px) above.
  // All *_px windows above are in that level's pixels.
  int block_px = 0;
  int reference_width_px = 256;
  // refine_with_neighbourhood(): which of the two parts to run.
  bool flags = true;
  bool pool_order = true;
  // spatial_pass() (skin_refit.hpp): first, a skin's systematic shortfall
  // taken as a local bias (local_bias.hpp); off by default.
  LocalBiasOptions local_bias;
  bool IsValid(std::string* error) const;
};

struct NeighbourhoodSummary {
  std::size_t flagged_touching = 0;   // pixels flagged because their region touches a flagged one
  std::size_t flagged_holes = 0;      // explained pixels enclosed by flagged ones
  std::size_t order_to_4 = 0, order_to_2 = 0;
  int passes = 0;
  int block_px = 1;  // the level the flag pass ran on
};

// The flag pass's block size for a width × height image under these options.
int neighbourhood_block_px(int width, int height, const NeighbourhoodOptions& options);

// measured: width·height·channels (the estimator's input), estimates: width·height,
// the first pass's output, updated in place (flags, and for changed orders the
// refitted pixel). Throws std::invalid_argument on size mismatch.
NeighbourhoodSummary refine_flags_with_neighbourhood(const Estimator& estimator, std::span<const float> measured,
                                                     int width, int height, std::span<PixelEstimate> estimates,
                                                     const NeighbourhoodOptions& options = {});
// Both (as options.flags / options.pool_order say), flags first so that
// flagged pixels do not vote on the order; summary's flag and order counts
// are recounted from estimates.
NeighbourhoodSummary refine_with_neighbourhood(const Estimator& estimator, std::span<const float> measured, int width,
                                               int height, std::span<PixelEstimate> estimates, EstimateSummary& summary,
                                               const NeighbourhoodOptions& options = {},
                                               std::span<const OtherOrderFit> other = {});
// other: empty, or one per estimate (std::invalid_argument otherwise).
NeighbourhoodSummary pool_model_order(const Estimator& estimator, std::span<const float> measured, int width,
                                      int height, std::span<PixelEstimate> estimates,
                                      const NeighbourhoodOptions& options = {},
                                      std::span<const OtherOrderFit> other = {});

}  // namespace chromo::estimation
