// The white target in a subject's frame (maps/white_target_pixels.hpp): its
// albedo is ρ in every channel within the channel's noise; skin, a bright
// highlight and NaN are not; bad input is named.
#include <cmath>
#include <limits>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "chromo/maps/white_target_pixels.hpp"

namespace chromo::maps {
namespace {

estimation::MeasurementSet four_channels(double read_sigma) {
  estimation::MeasurementSet set;
  for (const char* name : {"D65'.R", "D65'.G", "D65'.B", "blue.B"}) {
    estimation::MeasurementChannel channel;
    channel.name = name;
    channel.noise.read_sigma = read_sigma;
    channel.noise.shot_coefficient = 0;
    channel.noise.white_coefficient = 0;
    set.channels.push_back(channel);
  }
  return set;
}

TEST(WhiteTargetPixels, OnlyPixelsAtTheTargetsReflectanceInEveryChannelWithinNoise) {
  const double rho = 0.99, sigma = 0.01;  // allowed: 4σ + 3% of ρ = 0.0697
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> measured = {
      0.99f, 0.99f, 0.99f, 0.99f,      // the target
      1.05f, 0.93f, 1.0f, 0.95f,       // within 0.0697 in every channel
      0.99f, 0.99f, 0.99f, 0.91f,      // one channel 0.08 away: not the target
      0.62f, 0.45f, 0.35f, 0.30f,      // light skin
      1.10f, 0.96f, 0.86f, 0.80f,      // a strong highlight on skin
      0.99f, 0.99f, nan, 0.99f,        // a NaN channel
  };
  const auto white = white_target_pixels(measured, four_channels(sigma), rho);
  EXPECT_EQ(white, (std::vector<std::uint8_t>{1, 1, 0, 0, 0, 0}));
  // A noisier channel widens its own allowance: 4 × 0.03 + 0.0297 = 0.1497.
  EXPECT_EQ(white_target_pixels(measured, four_channels(0.03), rho), (std::vector<std::uint8_t>{1, 1, 1, 0, 0, 0}));
}

TEST(WhiteTargetPixels, BadInputIsNamed) {
  const std::vector<float> five = {1, 1, 1, 1, 1};
  EXPECT_THAT([&] { white_target_pixels(five, four_channels(0.01), 0.99); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("not whole pixels of 4 channels")));
  const std::vector<float> four = {1, 1, 1, 1};
  EXPECT_THAT([&] { white_target_pixels(four, four_channels(0.01), 0); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("white reflectance")));
  EXPECT_THAT([&] { white_target_pixels(four, four_channels(0.01), std::nan("")); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("white reflectance")));
}

}  // namespace
}  // namespace chromo::maps
