#pragma once
// Exposure metering on the white target (docs/daemon.md "Exposure per
// capture"): what the sequencer reads from a metering frame and how it picks
// the next exposure. Pure functions; the sequencer takes the frames.
//
// Levels: per colour channel (Bayer RGGB sites, RGB8's three samples, mono:
// one channel shown as R = G = B), the mean sample over the whole frame as a
// share of the format's full scale, and the share of samples at full scale.
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
  std::array<double, 3> clipped{};  // share of the channel's samples at full scale
  int brightest_channel() const;
};

// Throws std::invalid_argument when the samples do not match the geometry.
FrameLevels frame_levels(std::span<const std::uint8_t> samples, int width, int height, drivers::PixelFormat format);

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

}  // namespace chromo::daemon
