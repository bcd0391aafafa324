#pragma once
// Exposure metering on the white target (docs/daemon.md "Exposure per
// capture"): what the sequencer reads from a metering frame and how it picks
// the next exposure. Pure functions; the sequencer takes the frames.
//
// Levels: per colour channel (Bayer RGGB sites, RGB8's three samples, mono:
// one channel shown as R = G = B), the mean sample over a region of the frame
// as a share of the format's full scale, and the share of the region's
// samples at full scale. Regions: kWhole, the whole frame; kLit, the part
// that sees the lit target (issue 21: a posed camera sees the white target
// in perspective with dark around it, and a whole-frame mean would drive the
// target into clipping): per channel, when the frame has a dark surround
// (its 2nd percentile below half its 98th), the samples at or above the
// midpoint of the two; otherwise the whole frame, so a camera whose target
// fills the frame meters as with kWhole. The sequencer meters on kLit.
//
// Next exposure from a frame taken at exposure t: with b the brightest
// channel's mean and d that channel's dark level (the session's dark frames;
// 0 before any), the camera is taken as linear above the dark, so the
// exposure putting b at the target share s is t·(s − d)/(b − d). A frame
// with more than 0.1% of a channel's samples at full scale (or b ≥ 0.99) is
// clipped: its mean says too little, so the next exposure is at most half of
// t. A frame showing no signal (b − d < 10⁻⁴) tries 16·t. Every exposure is
// clamped to the camera's range [min, max]. Done when the predicted change
// is within the tolerance (default 3%), or the white cannot reach the share:
// measured at the maximum exposure and still short (at_limit, the share
// reached is what the frames get) or clipped at the minimum.

#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "chromo/drivers/camera.hpp"

namespace chromo::daemon {

struct FrameLevels {
  std::array<double, 3> mean{};     // R, G, B: share of full scale
  std::array<double, 3> clipped{};  // share of the region's samples at full scale
  std::array<double, 3> region_share{};  // share of the channel's samples in the region
  int brightest_channel() const;
};

enum class FrameRegion { kWhole, kLit };
inline constexpr double kLitLowPercentile = 0.02, kLitHighPercentile = 0.98;

// Throws std::invalid_argument when the samples do not match the geometry.
FrameLevels frame_levels(std::span<const std::uint8_t> samples, int width, int height, drivers::PixelFormat format,
                         FrameRegion region = FrameRegion::kWhole);

struct MeteringTarget {
  double white_share = 0.8;         // the brightest channel's mean, share of full scale
  double tolerance = 0.03;          // relative
  double min_exposure_us = 1, max_exposure_us = 10e6;
  std::array<double, 3> dark{};     // dark level per channel, share of full scale
};

struct MeteringDecision {
  double next_exposure_us = 0;
  bool done = false;
  bool at_limit = false;  // the target share cannot be reached within the camera's range
  bool clipped = false;   // the frame was clipped
};

MeteringDecision next_metering_exposure(double exposure_us, const FrameLevels& levels, const MeteringTarget& target);

// Subject metering (docs/daemon.md "Subject exposure"): per channel, the
// `percentile` of the frame's samples that are not white-like. A cell (a
// Bayer frame's 2×2 RGGB quad, else a pixel) is white-like when any of its
// samples reaches its channel's `white_like_from` (share of full scale);
// white-like cells grown by a margin of max(kSubjectWhiteLikeMarginCells,
// kSubjectWhiteLikeMarginShare × the frame's width in cells) cells (the
// target's edge: blur and sampling put its pixels between skin and white)
// are left out. The sequencer sets white_like_from at the dark level plus
// kSubjectWhiteLikeShare of the white's signal at the same exposure, so the
// white target or a reference strip in the subject's view (albedo near
// ρ_white), a specular highlight and anything clipped are not metered: a
// strip at the 99th percentile would keep the skin near its white's exposure.
// Skin's albedo stays well below it.
inline constexpr double kSubjectWhiteLikeShare = 0.9;
inline constexpr int kSubjectWhiteLikeMarginCells = 2;
inline constexpr double kSubjectWhiteLikeMarginShare = 0.01;
struct SubjectLevels {
  std::array<double, 3> level{};  // share of full scale (dark included); 0 when every cell is left out
  double white_like_share = 0;    // share of the frame's cells left out (white-like or within the margin)
};
// Throws std::invalid_argument when the samples do not match the geometry or
// the percentile is outside (0, 1].
SubjectLevels subject_levels(std::span<const std::uint8_t> samples, int width, int height, drivers::PixelFormat format,
                             double percentile, const std::array<double, 3>& white_like_from);

}  // namespace chromo::daemon
