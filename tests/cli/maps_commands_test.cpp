// The real `chromo make-maps-test-data`, `relight`, `flush` and `import-maps`:
// exit statuses, printed numbers, and bad input leaving nothing behind.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

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
