// Region statistics (maps/region_statistics.hpp) on a real maps.exr written
// and read back: known values give known mean, SD and percentiles; flagged
// and outside-the-field pixels are counted apart; bad regions are refused
// naming the field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>

#include <unistd.h>

#include "chromo/maps/region_statistics.hpp"

namespace fs = std::filesystem;
using namespace chromo;
using ::testing::HasSubstr;

namespace {

// 10×6 map: Cm = 1 + x + 10·y (so a rectangle holds known integers), flags 0
// except a dark pixel, a no_reference pixel and a NaN value.
files::FloatImage written_and_read_back() {
  files::FloatImage maps;
  maps.width = 10, maps.height = 6;
  maps.channel_names = {"Cm", "flags"};
  maps.channels.assign(2, std::vector<float>(60, 0.0f));
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 10; ++x) maps.channels[0][y * 10 + x] = static_cast<float>(1 + x + 10 * y);
  maps.channels[1][1 * 10 + 2] = 3;  // dark: masked
  maps.channels[1][2 * 10 + 3] = 8;  // no_reference: outside the field
  maps.channels[0][3 * 10 + 4] = std::numeric_limits<float>::quiet_NaN();  // outside too
  maps.channels[1][3 * 10 + 5] = 4;  // specular: skin, counted
  const fs::path file = fs::path(::testing::TempDir()) / ("region-stats-" + std::to_string(::getpid()) + ".exr");
  files::write_exr(file, maps);
  files::FloatImage read = files::read_exr(file);
  fs::remove(file);
  return read;
}

TEST(RegionStatistics, KnownValuesGiveKnownFiguresAndMaskedPixelsAreCountedApart) {
  const files::FloatImage maps = written_and_read_back();
  // Columns 1-6, rows 1-3: values 12-17, 22-27, 32-37 less 13 (dark), 24 (no_reference), 35 (NaN).
  const maps::RegionStatistics s = maps::region_statistics(maps, "Cm", {1, 1, 6, 3});
  EXPECT_EQ(s.region_pixels, 18);
  EXPECT_EQ(s.pixels, 15);
  EXPECT_EQ(s.flagged_pixels, 1);
  EXPECT_EQ(s.outside_field_pixels, 2);
  EXPECT_EQ(s.unit, "volume fraction");
  std::vector<double> counted = {12, 14, 15, 16, 17, 22, 23, 25, 26, 27, 32, 33, 34, 36, 37};
  double mean = 0;
  for (double v : counted) mean += v / 15.0;
  double squares = 0;
  for (double v : counted) squares += (v - mean) * (v - mean);
  EXPECT_NEAR(s.mean, mean, 1e-12);
  EXPECT_NEAR(s.sd, std::sqrt(squares / 14.0), 1e-12);
  EXPECT_EQ(s.min, 12);
  EXPECT_EQ(s.max, 37);
  EXPECT_EQ(s.median, 25);                     // rank 7 of 0-14
  EXPECT_NEAR(s.p25, 16.5, 1e-12);             // rank 3.5: between 16 and 17
  EXPECT_NEAR(s.p1, 12 + 0.14 * 2, 1e-12);     // rank 0.14: between 12 and 14
  EXPECT_NEAR(s.p99, 36 + 0.86 * 1, 1e-12);    // rank 13.86: between 36 and 37
  // The flags channel itself counts every pixel with a value, masked or not.
  const maps::RegionStatistics flags = maps::region_statistics(maps, "flags", {1, 1, 6, 3});
  EXPECT_EQ(flags.pixels, 17);  // only no_reference is outside (its Cm NaN does not matter here)
  EXPECT_EQ(flags.outside_field_pixels, 1);
  const std::string csv = maps::region_statistics_csv({s});
  EXPECT_THAT(csv, HasSubstr("channel,unit,x,y,width,height,region_pixels,pixels,"));
  EXPECT_THAT(csv, HasSubstr("\nCm,volume fraction,1,1,6,3,18,15,1,2,"));
}

TEST(RegionStatistics, AnEmptySelectionIsNaNAndBadRegionsAreRefusedNamingTheField) {
  const files::FloatImage maps = written_and_read_back();
  const maps::RegionStatistics none = maps::region_statistics(maps, "Cm", {4, 3, 1, 1});  // the NaN pixel
  EXPECT_EQ(none.pixels, 0);
  EXPECT_TRUE(std::isnan(none.mean));
  EXPECT_THAT([&] { maps::region_statistics(maps, "Cm", {5, 0, 6, 2}); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("region: 5,0 6×2 is not inside the 10×6 map")));
  EXPECT_THAT([&] { maps::region_statistics(maps, "Hb", {0, 0, 1, 1}); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("channel: \"Hb\" is not in the file (it has Cm, flags)")));
  EXPECT_EQ(maps::parse_pixel_rectangle("3,4,5,6", "--region").height, 6);
  for (const char* bad : {"3,4,5", "3,4,5,6,7", "a,4,5,6", "3,4,0,6", "3, 4,5,6", ""})
    EXPECT_THAT([&] { maps::parse_pixel_rectangle(bad, "--region"); },
                ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("--region: \""))) << bad;
}

}  // namespace
