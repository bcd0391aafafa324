// The real `chromo make-maps-test-data`, `relight`, `flush`, `import-maps` and `maps stats`:
// exit statuses, printed numbers, and bad input leaving nothing behind.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "chromo/files/float_image.hpp"
#include "run_chromo.hpp"

using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

struct MapsCommands : ::testing::Test {
  // One folder per test and process: ctest runs the tests of this file in parallel.
  fs::path dir = fs::path(::testing::TempDir()) /
                 ("chromo-maps-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "-" +
                  std::to_string(::getpid()));
  std::string d(const std::string& name) const { return (dir / name).string(); }
  void SetUp() override {
    fs::remove_all(dir);
    ASSERT_EQ(run_chromo("make-maps-test-data --out " + d("scene") + " --width 48 --height 36").exit_status, 0);
    const Result estimate =
        run_chromo("estimate " + d("scene/MEASUREMENT.json") + " --out " + d("est") + " --model 4d --cache-dir " + d("cache"));
    ASSERT_EQ(estimate.exit_status, 0) << estimate.output;
  }
  void TearDown() override { fs::remove_all(dir); }
};

TEST_F(MapsCommands, RelightFlushAndImportRunEndToEnd) {
  const Result relight = run_chromo("relight " + d("est/maps.exr") + " --illuminant " + d("scene/d65prime.csv") +
                                    " --photo " + d("scene/d65prime.exr") + " --out " + d("relit"));
  ASSERT_EQ(relight.exit_status, 0) << relight.output;
  EXPECT_THAT(relight.output, HasSubstr("ΔE94 photograph vs reconstruction: mean"));
  EXPECT_TRUE(fs::exists(dir / "relit" / "panel.png"));

  const Result flush = run_chromo("flush " + d("est/maps.exr") + " --scale ch=1.6,che=2.0 --ellipse 24,18,10,8 --feather 3 --out " +
                                  d("flushed"));
  ASSERT_EQ(flush.exit_status, 0) << flush.output;
  EXPECT_THAT(flush.output, HasSubstr("values clamped to MODEL.md's ranges"));

  const Result import = run_chromo("import-maps --melanin " + d("scene/melanin.png") + " --hemoglobin " +
                                   d("scene/hemoglobin.png") + " --albedo " + d("scene") + " --out " + d("imported") +
                                   " --cache-dir " + d("cache"));
  ASSERT_EQ(import.exit_status, 0) << import.output;
  EXPECT_THAT(import.output, HasSubstr("2D mapping"));
  EXPECT_TRUE(fs::exists(dir / "imported" / "comparison.json"));
}

// `chromo maps stats` on a maps.exr written here: the numbers equal those
// computed from the file's own pixels (skin: flag 0 or 4), CSV and JSON.
TEST(MapsStats, PrintsTheRegionsStatisticsFromMapsExr) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("chromo-maps-stats-" + std::to_string(::getpid()));
  fs::create_directories(dir / "results");
  const int w = 40, h = 30;
  std::vector<float> ch(static_cast<std::size_t>(w) * h), flags(ch.size(), 0.0f);
  for (std::size_t i = 0; i < ch.size(); ++i) ch[i] = 0.01f + 0.0007f * static_cast<float>((i * 37) % 101);
  for (std::size_t i = 0; i < ch.size(); i += 13) flags[i] = 3;  // dark: masked
  flags[10 * w + 12] = 8;                                       // no_reference: outside the field
  chromo::files::write_exr(dir / "results" / "maps.exr",
                           chromo::files::FloatImage{w, h, {"Cm", "Ch", "Bm", "Che", "flags"}, {ch, ch, ch, ch, flags}});
  const Result r = run_chromo("maps stats " + dir.string() + " --region 5,4,30,20 --channel Ch --json");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  const nlohmann::json printed = nlohmann::json::parse(r.output);
  const nlohmann::json& s = printed["statistics"][0];
  std::vector<double> skin;
  for (int y = 4; y < 24; ++y)
    for (int x = 5; x < 35; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      if (flags[i] == 0) skin.push_back(ch[i]);
    }
  std::sort(skin.begin(), skin.end());
  double mean = 0;
  for (double v : skin) mean += v;
  mean /= static_cast<double>(skin.size());
  EXPECT_EQ(s["pixels"].get<std::size_t>(), skin.size());
  EXPECT_EQ(s["region_pixels"].get<int>(), 600);
  EXPECT_EQ(s["outside_field_pixels"].get<int>(), 1);
  EXPECT_EQ(s["flagged_pixels"].get<std::size_t>(), 600 - 1 - skin.size());
  EXPECT_NEAR(s["mean"].get<double>(), mean, 1e-12);
  EXPECT_EQ(s["min"].get<double>(), skin.front());
  EXPECT_EQ(s["max"].get<double>(), skin.back());
  const Result csv = run_chromo("maps stats " + dir.string() + " --region 5,4,30,20");
  ASSERT_EQ(csv.exit_status, 0) << csv.output;
  EXPECT_EQ(std::count(csv.output.begin(), csv.output.end(), '\n'), 5);  // header + Cm, Ch, Bm, Che
  EXPECT_THAT(csv.output, HasSubstr("\nCh,volume fraction,5,4,30,20,600,"));
  for (const auto& [arguments, expected] : {
           std::pair{" --region 30,20,20,20", "region: 30,20 20×20 is not inside the 40×30 map"},
           std::pair{" --region 1,2,3", "--region: \"1,2,3\" is not x,y,width,height"},
           std::pair{" --region 1,2,3,4 --channel Hb", "--channel: \"Hb\" is not in the file"},
           std::pair{" --region 1,2,3,4 --camera cam9", "no maps.exr in results/cam9/"}}) {
    const Result bad = run_chromo("maps stats " + dir.string() + arguments);
    EXPECT_EQ(bad.exit_status, 2) << arguments << "\n" << bad.output;
    EXPECT_THAT(bad.output, HasSubstr(expected)) << arguments;
  }
  const Result missing = run_chromo("maps stats " + (dir / "missing").string() + " --region 1,2,3,4");
  EXPECT_EQ(missing.exit_status, 2);
  EXPECT_THAT(missing.output, HasSubstr("missing: no such file or folder"));
  fs::remove_all(dir);
}

TEST_F(MapsCommands, BadInputExitsTwoNamingTheProblemAndWritesNothing) {
  struct Case {
    std::string arguments, expected;
  };
  for (const Case& c : {
           Case{"relight " + d("missing.exr") + " --out " + d("out"), "maps: "},
           Case{"relight " + d("est/maps.exr") + " --illuminant 900K --out " + d("out"), "illuminant: "},
           Case{"relight " + d("est/maps.exr") + " --photo " + d("scene/blue.exr") + " --out " + d("out"), "photograph: "},
           Case{"flush " + d("est/maps.exr") + " --scale ch=2 --ellipse 500,500,5,5 --out " + d("out"), "ellipse: "},
           Case{"flush " + d("est/maps.exr") + " --scale hb=2 --ellipse 20,20,5,5 --out " + d("out"), "scale: unknown parameter"},
           Case{"flush " + d("est/maps.exr") + " --scale ch=2 --mask " + d("scene/melanin.png") + " --ellipse 1,1,2,2 --out " + d("out"),
                "excludes"},
           Case{"import-maps --melanin " + d("scene/melanin.png") + " --hemoglobin " + d("relit.png") + " --albedo " +
                    d("scene") + " --out " + d("out"),
                "hemoglobin: "},
       }) {
    const Result r = run_chromo(c.arguments);
    EXPECT_EQ(r.exit_status, 2) << c.arguments << "\n" << r.output;
    EXPECT_THAT(r.output, HasSubstr(c.expected)) << c.arguments;
    EXPECT_FALSE(fs::exists(dir / "out")) << c.arguments;
  }
}

}  // namespace
