#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "chromo/maps/map_operations.hpp"
#include "maps_fixture.hpp"

namespace chromo::maps {
namespace {

using ::testing::StartsWith;
using testing::fresh_directory;
using testing::nothing_written;
using testing::uniform_maps;
using testing::write_maps;

struct FlushFixture : ::testing::Test {
  std::filesystem::path dir = fresh_directory("flush");
  void TearDown() override { std::filesystem::remove_all(dir); }
  FlushOptions options(const std::string& maps = "maps.exr") {
    FlushOptions o;
    o.maps = dir / maps, o.out = dir / "out";
    return o;
  }
};

// The mask's feathering profile, seen through the edited maps: along the row
// through the centre, Ch/Ch0 = 1 + m·(2 − 1) with m ramping linearly from 1
// to 0 over 2·feather = 8 px centred on the outline (x ≈ 30 + 20 = 50).
TEST_F(FlushFixture, FeatheringRampsTheScaleLinearlyAcrossTheOutline) {
  write_maps(dir / "maps.exr", uniform_maps(80, 61, 0.05f, 0.04f, 0.7f, 0.02f));
  FlushOptions o = options();
  o.scale.ch = 2.0, o.scale.che = 1.5;
  o.ellipse = EllipseShape{30, 30, 20, 20, 0};
  o.feather_px = 4;
  const FlushSummary s = flush_to_files(o);
  const ParameterMaps edited = read_parameter_maps(dir / "out" / "maps.exr");
  auto m_at = [&](int x) { return edited.ch[30 * 80 + x] / 0.04 - 1.0; };
  EXPECT_NEAR(m_at(30), 1.0, 1e-6);   // centre
  EXPECT_NEAR(m_at(45), 1.0, 1e-6);   // 5 px inside the outline: beyond the ramp
  EXPECT_NEAR(m_at(58), 0.0, 1e-6);   // 8 px outside
  int ramp = 0;
  for (int x = 40; x < 60; ++x) {
    EXPECT_LE(m_at(x + 1), m_at(x) + 1e-6) << x;  // monotone
    if (m_at(x) > 1e-6 && m_at(x) < 1 - 1e-6) ++ramp;
    if (m_at(x + 1) > 1e-6 && m_at(x) < 1 - 1e-6) {
      EXPECT_NEAR(m_at(x) - m_at(x + 1), 1.0 / 8, 0.01) << x;  // linear
    }
  }
  EXPECT_EQ(ramp, 8);  // 2·feather pixels
  EXPECT_NEAR(edited.che[30 * 80 + 30], 0.03, 1e-6);
  EXPECT_FLOAT_EQ(edited.cm[30 * 80 + 30], 0.05f);
  EXPECT_EQ(s.edit.values_clamped, 0u);
  EXPECT_GT(s.change_delta_e94.max, 1.0);  // doubling blood is visible
  for (const char* f : {"maps.exr", "mask.png", "before.png", "after.png", "panel.png", "flush.json"})
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / f)) << f;
  // The other channels of the input survive the edit.
  EXPECT_NO_THROW(files::read_exr(dir / "out" / "maps.exr").channel("flags"));
}

TEST_F(FlushFixture, OutOfRangeResultsAreClampedAndTheShareReported) {
  ParameterMaps maps = uniform_maps(10, 10, 0.05f, 0.25f, 0.7f, 0.02f);
  write_maps(dir / "maps.exr", maps);
  FlushOptions o = options();
  o.scale.ch = 2.0;  // 0.5 > 0.32
  o.polygon = PolygonShape{{{0, 0}, {9, 0}, {9, 9}, {0, 9}}};
  const FlushSummary s = flush_to_files(o);
  EXPECT_EQ(s.edit.pixels_touched, 100u);
  EXPECT_EQ(s.edit.clamped_ch, 100u);
  EXPECT_DOUBLE_EQ(s.edit.clamped_share, 0.25);
  EXPECT_FLOAT_EQ(read_parameter_maps(dir / "out" / "maps.exr").ch[55], 0.32f);
}

TEST_F(FlushFixture, BadInputNamesTheFieldAndWritesNothing) {
  write_maps(dir / "maps.exr", uniform_maps(32, 24, 0.05f, 0.04f, 0.7f, 0.0f));
  cv::imwrite((dir / "small_mask.png").string(), cv::Mat(10, 10, CV_8U, cv::Scalar(255)));
  cv::imwrite((dir / "empty_mask.png").string(), cv::Mat(24, 32, CV_8U, cv::Scalar(0)));
  auto expect_refused = [&](FlushOptions o, const std::string& field) {
    try {
      flush_to_files(o);
      ADD_FAILURE() << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), StartsWith(field));
    }
    EXPECT_TRUE(nothing_written(dir / "out")) << field;
  };
  FlushOptions o = options();
  o.scale.ch = 1.5;
  o.ellipse = EllipseShape{-100, -100, 10, 10, 0};  // outside the image
  expect_refused(o, "ellipse: ");
  o.ellipse.reset();
  o.mask = dir / "small_mask.png";
  expect_refused(o, "mask: ");
  o.mask = dir / "empty_mask.png";
  expect_refused(o, "mask: ");
  o.mask = dir / "no_such_mask.png";
  expect_refused(o, "mask: ");
  o.mask.clear();
  expect_refused(o, "mask: ");  // no region at all
  o.ellipse = EllipseShape{10, 10, 5, 5, 0};
  o.scale.che = -1;
  expect_refused(o, "scale.che: ");
  o.scale.che = 1;
  o.feather_px = -2;
  expect_refused(o, "feather_px: ");
  o.feather_px = 2;
  o.illuminant = "nope";
  expect_refused(o, "illuminant: ");
  o.illuminant = "D65";
  o.maps = dir / "missing.exr";
  expect_refused(o, "maps: ");
}

}  // namespace
}  // namespace chromo::maps
