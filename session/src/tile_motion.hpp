#pragma once
// The motion between two captures as the consensus of tiles (registration.hpp:
// the still decision and the check of ECC's warp).
//
// Why tiles: captures under different LEDs see ink, marker and subjects of
// different colour balance with different contrast. ECC fits one gain and
// offset to the whole frame, and across the edge of a region whose own factor
// differs the mismatch pulls the alignment (0.354 px on a still six-LED
// real-skin scene, docs/estimation.md "Why the still scene moves"). That pull
// is local: each tile holding such an edge is pulled its own way, while a
// subject's motion moves every tile alike. Each tile's translation is measured
// with its own gain and offset; a shift and rotation are fitted to the tiles'
// translations, the tiles that disagree with it by far more than the rest are
// left out, and the spread of the rest about the fit is the noise of the
// motion: it holds the photometric pulls that remain, not only the pixels' noise.

#include <opencv2/core.hpp>

namespace chromo::session::registration_detail {

// Tile side at the working level (px): a quarter of the frame's shorter
// side, within [kSmallestTileSidePx, kTileSidePx] (at least 4 tiles across a
// small frame: a 160 × 64 px scene gets 16 px tiles). The frame is measured
// at a pyramid level of at most ~1.2 MP, as the block noise is.
inline constexpr int kTileSidePx = 48;
inline constexpr int kSmallestTileSidePx = 16;
// The view is textured enough for a consensus only where at least half of
// the measured tiles have a texture this far above the noise in their
// gradients (TranslationFit::gradient_snr). Where the noise is comparable to
// the texture, the gradient least squares keeps only ~snr / (1 + snr) of the
// motion from its start (errors in the regressors), so such tiles agree on no
// motion. Measured (still37d): on the rendered session's smooth skin
// (tests/simulators/subject_motion_test, 128 × 96 px) 3 of 20 tiles reach 4
// and the rest have snr ≈ 1: with their consensus, a 0.5 px motion was called
// still and a 5 px drift kept the coarse warp's 1.2 px error; without it ECC
// decides as before. On the real-skin bench scenes the median tile's is 36
// (method, subjects 041-050, seed 1; 2 of 65 below 3). Leaving the
// low-snr tiles out one by one instead (tried) raised the moved six-LED
// scenes' corner error at 1 px from 0.10 to 0.46 px and missed one capture.
inline constexpr double kMinimumTileGradientSnr = 4.0;
// Fewer measured tiles than this: no consensus (a featureless or tiny view).
inline constexpr int kMinimumTiles = 8;
// A tile whose translation departs from the fit by more than this many of the
// tiles' robust spread (per axis, from their residuals' median length) is left out.
inline constexpr double kTileOutlierSpreads = 3.5;
// registration.cpp: the tiles start from the identity while ECC's coarse warp
// moves every image corner by at most this (px), else from the coarse warp.
inline constexpr double kTilesFromIdentityReachPx = 1.0;

struct TileMotion {
  bool measured = false;  // at least kMinimumTiles tiles measured their translation, half of them textured
  cv::Mat warp;           // 2×3 CV_32F, reference pixel → moving pixel (ECC's convention), base ∘ the tiles' fit
  double noise_px = 0;    // standard error of the fit's displacement at the worst image corner (√ of both axes' variances)
  int tiles_measured = 0, tiles_kept = 0;
};

// ref, mov: CV_32F, one size; ref_valid, mov_valid: CV_8U on each one's
// grid, non-zero where it is data (a tile's pixel takes part where both are,
// the moving mask resampled by `base_warp`). base_warp: 2×3 CV_32F, the starting alignment (the identity, or
// the coarse pyramid levels' warp); the tiles measure what remains after it
// (sub-pixel to a few px). Each tile (side as above): translation_least_squares (own gain and
// offset, 5 steps), voting when 3σ ≤ kTranslationFallbackUncertaintyPx; no
// consensus when fewer than half of them reach kMinimumTileGradientSnr. The
// fit: t(x) = T + θ·(−(y − c_y), x − c_x) about the frame's centre c, least
// squares over the kept tiles (outliers left out in up to 5 rounds; if more
// than half would go, none is left out). Noise: the kept tiles' residual
// variance s² = Σ|r|² / (2n − 3) through (AᵀA)⁻¹ to the corners.
TileMotion tile_motion(const cv::Mat& ref, const cv::Mat& ref_valid, const cv::Mat& mov, const cv::Mat& mov_valid,
                       const cv::Mat& base_warp);

}  // namespace chromo::session::registration_detail
