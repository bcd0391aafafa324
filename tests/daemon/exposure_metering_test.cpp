// Exposure metering's arithmetic (daemon/internal/capture/exposure_metering.hpp) on frames
// made here: levels per Bayer colour, and the next exposure of a linear
// camera converging on the target share, clipping, and the camera's limits.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <cstring>

#include "chromo/daemon/internal/capture/exposure_metering.hpp"

namespace chromo::daemon {
namespace {

// A BayerRG12 frame (16-bit samples) whose R, G, B sites hold these DN.
std::vector<std::uint8_t> bayer_frame(int width, int height, std::uint16_t r, std::uint16_t g, std::uint16_t b) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(width) * height * 2);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::uint16_t v = (y % 2 == 0 && x % 2 == 0) ? r : (y % 2 && x % 2) ? b : g;
      std::memcpy(&bytes[(static_cast<std::size_t>(y) * width + x) * 2], &v, 2);
    }
  return bytes;
}

TEST(ExposureMetering, LevelsPerBayerColourAndClippedShare) {
  const auto frame = bayer_frame(8, 6, 1000, 2000, 4095);
  const FrameLevels levels = frame_levels(frame, 8, 6, drivers::PixelFormat::kBayerRG12);
  EXPECT_NEAR(levels.mean[0], 1000.0 / 4095, 1e-12);
  EXPECT_NEAR(levels.mean[1], 2000.0 / 4095, 1e-12);
  EXPECT_NEAR(levels.mean[2], 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(levels.clipped[2], 1.0);
  EXPECT_DOUBLE_EQ(levels.clipped[0], 0.0);
  EXPECT_EQ(levels.brightest_channel(), 2);
  EXPECT_THROW(frame_levels(frame, 8, 5, drivers::PixelFormat::kBayerRG12), std::invalid_argument);
}

// A posed camera's white: lit sites inside a centred rectangle of a quarter
// of the frame, the dark level (64 DN) around it.
TEST(ExposureMetering, TheLitRegionIsMeteredWithoutItsDarkSurround) {
  const int width = 40, height = 30;
  auto frame = bayer_frame(width, height, 64, 64, 64);
  const auto lit = bayer_frame(width, height, 1000, 2000, 3000);
  for (int y = height / 4; y < 3 * height / 4; ++y)
    for (int x = width / 4; x < 3 * width / 4; ++x)
      std::memcpy(&frame[(static_cast<std::size_t>(y) * width + x) * 2], &lit[(static_cast<std::size_t>(y) * width + x) * 2], 2);
  const FrameLevels whole = frame_levels(frame, width, height, drivers::PixelFormat::kBayerRG12);
  const FrameLevels region = frame_levels(frame, width, height, drivers::PixelFormat::kBayerRG12, FrameRegion::kLit);
  EXPECT_NEAR(region.mean[0], 1000.0 / 4095, 1e-12);
  EXPECT_NEAR(region.mean[1], 2000.0 / 4095, 1e-12);
  EXPECT_NEAR(region.mean[2], 3000.0 / 4095, 1e-12);
  EXPECT_NEAR(region.region_share[1], 0.25, 0.01);
  EXPECT_LT(whole.mean[1], 0.35 * 2000.0 / 4095);  // the surround pulls the whole frame's mean down
  // Clipping inside the lit part is the lit part's share.
  for (int x = width / 4; x < width / 2; ++x) {
    const std::uint16_t full = 4095;
    std::memcpy(&frame[(static_cast<std::size_t>(height / 2) * width + x) * 2], &full, 2);
  }
  const FrameLevels clipped = frame_levels(frame, width, height, drivers::PixelFormat::kBayerRG12, FrameRegion::kLit);
  const FrameLevels clipped_whole = frame_levels(frame, width, height, drivers::PixelFormat::kBayerRG12);
  EXPECT_GT(clipped.clipped[1], 3 * clipped_whole.clipped[1]);
  // A frame lit everywhere meters the same in both regions.
  const auto flat = bayer_frame(width, height, 1000, 2000, 3000);
  const FrameLevels a = frame_levels(flat, width, height, drivers::PixelFormat::kBayerRG12);
  const FrameLevels b = frame_levels(flat, width, height, drivers::PixelFormat::kBayerRG12, FrameRegion::kLit);
  for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(a.mean[c], b.mean[c]);
}

// A linear camera: mean = dark + rate·t (clipped at 1).
FrameLevels linear(double rate_per_us, double dark, double exposure_us) {
  FrameLevels levels;
  const double v = dark + rate_per_us * exposure_us;
  levels.mean = {0.5 * std::min(v, 1.0), std::min(v, 1.0), 0.3 * std::min(v, 1.0)};
  levels.clipped = {0, v >= 1 ? 0.5 : 0.0, 0};
  return levels;
}

TEST(ExposureMetering, ConvergesOnTheTargetShareOfALinearCamera) {
  MeteringTarget target;
  target.white_share = 0.8;
  target.dark = {0.004, 0.004, 0.004};
  double t = 2000;
  int frames = 0;
  MeteringDecision d;
  do {
    d = next_metering_exposure(t, linear(1e-5, 0.004, t), target);
    t = d.next_exposure_us;
    ++frames;
  } while (!d.done && frames < 6);
  EXPECT_TRUE(d.done);
  EXPECT_FALSE(d.at_limit);
  EXPECT_LE(frames, 2);
  EXPECT_NEAR(linear(1e-5, 0.004, t).mean[1], 0.8, 1e-9);
}

TEST(ExposureMetering, ClippedFramesHalveAndLimitsStop) {
  MeteringTarget target;
  target.white_share = 0.8;
  target.min_exposure_us = 100, target.max_exposure_us = 50000;
  // Clipped: the mean says too little, so at most half.
  MeteringDecision d = next_metering_exposure(40000, linear(1e-4, 0, 40000), target);
  EXPECT_TRUE(d.clipped);
  EXPECT_FALSE(d.done);
  EXPECT_LE(d.next_exposure_us, 20000);
  // Too dark even at the maximum: done, at the limit, the maximum kept.
  d = next_metering_exposure(50000, linear(1e-6, 0, 50000), target);
  EXPECT_TRUE(d.done);
  EXPECT_TRUE(d.at_limit);
  EXPECT_DOUBLE_EQ(d.next_exposure_us, 50000);
  // Below the maximum but wanting more: clamped to it, measured there next.
  d = next_metering_exposure(20000, linear(1e-6, 0, 20000), target);
  EXPECT_FALSE(d.done);
  EXPECT_DOUBLE_EQ(d.next_exposure_us, 50000);
  // Clipped at the minimum: done, at the limit.
  d = next_metering_exposure(100, linear(1, 0, 100), target);
  EXPECT_TRUE(d.done);
  EXPECT_TRUE(d.at_limit);
  // No signal: a much longer exposure.
  d = next_metering_exposure(1000, linear(0, 0, 1000), target);
  EXPECT_DOUBLE_EQ(d.next_exposure_us, 16000);
}

// Subject metering: skin-like texture (each site uniform in [400, 1000] DN
// of 4095, seeded) with a white strip over the right tenth at 3000 DN whose
// edge ramps over 6 columns (blur, sampling; without the margin its 5 columns
// above the skin, 1.6% of the samples, would be the 99th percentile). The strip and its edge are
// left out: the 99th percentile is the texture's alone, within 1%, where the
// whole frame's is in the strip; a texture-only frame leaves nothing out.
TEST(SubjectMetering, TheWhiteStripInViewIsLeftOutAndTheSkinMetered) {
  constexpr int width = 320, height = 240, strip_from = width - width / 10;
  constexpr double white_dn = 3000, dark_dn = 64;
  auto frame = [&](bool strip) {
    std::mt19937 random(7);
    std::uniform_real_distribution<double> skin(400, 1000);
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(width) * height * 2);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        double v = skin(random);
        if (strip) {
          const double t = std::clamp((x - (strip_from - 6)) / 6.0, 0.0, 1.0);  // the edge's ramp
          v = (1 - t) * v + t * white_dn;
        }
        const auto dn = static_cast<std::uint16_t>(std::lround(v));
        std::memcpy(&bytes[(static_cast<std::size_t>(y) * width + x) * 2], &dn, 2);
      }
    return bytes;
  };
  std::array<double, 3> white_like_from{};
  for (double& c : white_like_from) c = (dark_dn + kSubjectWhiteLikeShare * (white_dn - dark_dn)) / 4095;
  const SubjectLevels alone = subject_levels(frame(false), width, height, drivers::PixelFormat::kBayerRG12, 0.99,
                                             white_like_from);
  const SubjectLevels with_strip = subject_levels(frame(true), width, height, drivers::PixelFormat::kBayerRG12, 0.99,
                                                  white_like_from);
  EXPECT_DOUBLE_EQ(alone.white_like_share, 0.0);
  EXPECT_NEAR(with_strip.white_like_share, 0.1 + 2.0 / (width / 2), 0.02);  // the strip and its 2-cell margin
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(alone.level[c], 994.0 / 4095, 8.0 / 4095) << c;  // 400 + 0.99·600
    EXPECT_NEAR(with_strip.level[c] / alone.level[c], 1.0, 0.01) << c;
  }
  // The whole frame's 99th percentile (frame_levels' region) is the strip's.
  const std::array<double, 3> nothing_left_out{1.0, 1.0, 1.0};
  const SubjectLevels whole = subject_levels(frame(true), width, height, drivers::PixelFormat::kBayerRG12, 0.99,
                                             nothing_left_out);
  EXPECT_NEAR(whole.level[0], white_dn / 4095, 0.01);
  EXPECT_THROW(subject_levels(frame(true), width, height, drivers::PixelFormat::kBayerRG12, 1.5, white_like_from),
               std::invalid_argument);
  EXPECT_THROW(subject_levels(frame(true), width, height - 1, drivers::PixelFormat::kBayerRG12, 0.99, white_like_from),
               std::invalid_argument);
}

}  // namespace
}  // namespace chromo::daemon
