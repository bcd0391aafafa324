// `chromo make-real-skin-scene` and `chromo estimate` on it (issue 37): a
// still scene of measured skin spectra keeps the identity registration and
// every pixel finite, the σ maps are written, and the learned discrepancy
// flags far less of the skin than camera noise alone. (The default
// discrepancy is learned from all 50 shipped subjects, these included; the
// held-out figures are tests/estimation/model_discrepancy_test.cpp's and
// real_skin_bench's.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "chromo/files/float_image.hpp"
#include "run_chromo.hpp"

namespace {

namespace fs = std::filesystem;

fs::path fresh(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("chromo-real-skin-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

// Flagged share of skin at least 2 px inside its patch and away from the ink and marker.
double interior_skin_flagged(const chromo::files::FloatImage& truth, const chromo::files::FloatImage& maps) {
  const auto& spectrum = truth.channel("spectrum");
  const auto& region = truth.channel("region");
  const auto& flags = maps.channel("flags");
  std::size_t skin = 0, flagged = 0;
  for (int y = 2; y < truth.height - 2; ++y)
    for (int x = 2; x < truth.width - 2; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * truth.width + x;
      bool interior = spectrum[i] >= 0 && region[i] == 0;
      for (int dy = -2; interior && dy <= 2; ++dy)
        for (int dx = -2; interior && dx <= 2; ++dx) {
          const std::size_t j = static_cast<std::size_t>(y + dy) * truth.width + x + dx;
          interior = spectrum[j] == spectrum[i] && region[j] == 0;
        }
      if (!interior) continue;
      ++skin;
      flagged += flags[i] != 0;
    }
  return skin ? static_cast<double>(flagged) / skin : 1.0;
}

// Mean over subjects 0 … subjects−1 of the within-patch standard deviation
// of a map (its log when `log`), on the patch interior (region 0) both
// estimates a and b explain; patches with fewer than 50 such pixels skipped,
// at least subjects − 1 patches expected.
double within_patch_scatter(const chromo::files::FloatImage& truth, const chromo::files::FloatImage& a,
                            const chromo::files::FloatImage& b, const chromo::files::FloatImage& maps,
                            const std::string& name, bool log, int subjects) {
  const auto& spectrum = truth.channel("spectrum");
  const auto& region = truth.channel("region");
  double sum_sd = 0;
  int counted = 0;
  for (int s = 0; s < subjects; ++s) {
    double sum = 0, sum_sq = 0;
    int n = 0;
    for (std::size_t i = 0; i < spectrum.size(); ++i) {
      if (spectrum[i] != s || region[i] != 0 || a.channel("flags")[i] != 0 || b.channel("flags")[i] != 0) continue;
      const double v = log ? std::log(maps.channel(name)[i]) : maps.channel(name)[i];
      sum += v, sum_sq += v * v, ++n;
    }
    if (n < 50) continue;
    sum_sd += std::sqrt(std::max(0.0, sum_sq / n - (sum / n) * (sum / n)));
    ++counted;
  }
  EXPECT_GE(counted, subjects - 1);
  return counted ? sum_sd / counted : 0.0;
}

TEST(RealSkinScene, StillSceneKeepsTheIdentityAndTheLearnedDiscrepancyKeepsSkin) {
  const fs::path dir = fresh("six");
  const Result made = run_chromo("make-real-skin-scene --out " + (dir / "scene").string() +
                                 " --plan six-leds --subjects 021-030 --patch 24 --seed 3");
  ASSERT_EQ(made.exit_status, 0) << made.output;
  const Result learned = run_chromo("estimate " + (dir / "scene" / "MEASUREMENT.json").string() + " --out " +
                                    (dir / "learned").string() + " --threads 2");
  ASSERT_EQ(learned.exit_status, 0) << learned.output;
  const Result none = run_chromo("estimate " + (dir / "scene" / "MEASUREMENT.json").string() + " --out " +
                                 (dir / "none").string() + " --threads 2 --discrepancy none");
  ASSERT_EQ(none.exit_status, 0) << none.output;

  std::ifstream in(dir / "learned" / "summary.json");
  const auto summary = nlohmann::json::parse(in);
  ASSERT_EQ(summary["registration"].size(), 5u);
  for (const auto& r : summary["registration"]) EXPECT_FALSE(r["warped"].get<bool>()) << r.dump();
  EXPECT_EQ(summary["flag_counts"]["non_finite"].get<int>(), 0);
  EXPECT_GT(summary["uncertainty"]["median_sigma"]["Cm"].get<double>(), 0.0);

  const auto truth = chromo::files::read_exr(dir / "scene" / "truth.exr");
  const auto maps = chromo::files::read_exr(dir / "learned" / "maps.exr");
  const auto maps_none = chromo::files::read_exr(dir / "none" / "maps.exr");
  const double flagged = interior_skin_flagged(truth, maps), flagged_none = interior_skin_flagged(truth, maps_none);
  EXPECT_LE(flagged, 0.01);
  EXPECT_GT(flagged_none, 3 * flagged + 0.02);
  // Every explained pixel has a finite, positive σ for each parameter.
  const auto& flags = maps.channel("flags");
  for (const char* name : {"sigma_Cm", "sigma_Ch", "sigma_Bm", "sigma_Che"}) {
    const auto& sigma = maps.channel(name);
    std::size_t bad = 0;
    for (std::size_t i = 0; i < flags.size(); ++i) bad += flags[i] == 0 && !(std::isfinite(sigma[i]) && sigma[i] > 0);
    EXPECT_EQ(bad, 0u) << name;
  }
  fs::remove_all(dir);
}

// --prior real-skin (issue 37): on the method's four channels the estimate
// takes real skin's most probable parameters among those that explain the
// pixel, so within one subject's patch (one spectrum, ±3% texture) βm and
// ln Ch scatter less than from the data alone; flags are the data's.
TEST(RealSkinScene, PriorOfRealSkinSteadiesTheMethodsFourChannelEstimate) {
  const fs::path dir = fresh("prior");
  const Result made = run_chromo("make-real-skin-scene --out " + (dir / "scene").string() +
                                 " --plan method --subjects 021-026 --patch 24 --seed 3");
  ASSERT_EQ(made.exit_status, 0) << made.output;
  for (const std::string prior : {"none", "real-skin"}) {
    const Result r = run_chromo("estimate " + (dir / "scene" / "MEASUREMENT.json").string() + " --out " +
                                (dir / prior).string() + " --threads 2 --prior " + prior);
    ASSERT_EQ(r.exit_status, 0) << r.output;
  }
  const auto truth = chromo::files::read_exr(dir / "scene" / "truth.exr");
  const auto none = chromo::files::read_exr(dir / "none" / "maps.exr");
  const auto prior = chromo::files::read_exr(dir / "real-skin" / "maps.exr");
  auto scatter = [&](const chromo::files::FloatImage& maps, const std::string& name, bool log) {
    return within_patch_scatter(truth, none, prior, maps, name, log, 6);
  };
  const double bm_none = scatter(none, "Bm", false), bm_prior = scatter(prior, "Bm", false);
  const double ch_none = scatter(none, "Ch", true), ch_prior = scatter(prior, "Ch", true);
  std::printf("within-patch sd: Bm %.3f -> %.3f, ln Ch %.3f -> %.3f\n", bm_none, bm_prior, ch_none, ch_prior);
  EXPECT_LT(bm_prior, 0.7 * bm_none);
  EXPECT_LT(ch_prior, ch_none);
  // The flags are the data's: the same pixels flagged either way.
  std::size_t differ = 0;
  for (std::size_t i = 0; i < none.channel("flags").size(); ++i)
    differ += (none.channel("flags")[i] != 0) != (prior.channel("flags")[i] != 0);
  EXPECT_EQ(differ, 0u);
  const Result bad = run_chromo("estimate " + (dir / "scene" / "MEASUREMENT.json").string() + " --out " +
                                (dir / "bad").string() + " --prior forearm");
  EXPECT_NE(bad.exit_status, 0) << bad.output;
  EXPECT_NE(bad.output.find("--prior"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(dir / "bad"));
  fs::remove_all(dir);
}

// --skin-denoise on (issue 37): the multi-pixel estimate reaches the maps.
// On uniform patches of one measured spectrum each (no texture; the
// method's four channels, the cheaper estimate), the skin
// cells' parameters change and their within-patch scatter falls; the flags
// stay the per-pixel pass's; summary.json records which ran; a bad value is
// refused naming the option, writing nothing.
TEST(RealSkinScene, SkinDenoiseOnSteadiesUniformSkinAndKeepsTheFlags) {
  const fs::path dir = fresh("denoise");
  const Result made = run_chromo("make-real-skin-scene --out " + (dir / "scene").string() +
                                 " --plan method --subjects 031-034 --patch 20 --columns 4 --texture 0 --seed 2");
  ASSERT_EQ(made.exit_status, 0) << made.output;
  for (const std::string mode : {"off", "on"}) {
    const Result r = run_chromo("estimate " + (dir / "scene" / "MEASUREMENT.json").string() + " --out " +
                                (dir / mode).string() + " --threads 2 --skin-denoise " + mode);
    ASSERT_EQ(r.exit_status, 0) << r.output;
    std::ifstream in(dir / mode / "summary.json");
    const auto summary = nlohmann::json::parse(in);
    EXPECT_EQ(summary["skin_denoise"]["enabled"].get<bool>(), mode == "on");
    if (mode == "on") EXPECT_GT(summary["skin_denoise"]["mean_pixels_averaged"].get<double>(), 20.0);
  }
  const auto truth = chromo::files::read_exr(dir / "scene" / "truth.exr");
  const auto off = chromo::files::read_exr(dir / "off" / "maps.exr");
  const auto on = chromo::files::read_exr(dir / "on" / "maps.exr");
  for (const char* name : {"Cm", "Bm"}) {
    const double before = within_patch_scatter(truth, off, on, off, name, false, 4);
    const double after = within_patch_scatter(truth, off, on, on, name, false, 4);
    std::printf("within-patch sd %s: off %.4f, on %.4f\n", name, before, after);
    EXPECT_LT(after, 0.6 * before) << name;
  }
  std::size_t changed = 0, differ = 0, explained = 0;
  for (std::size_t i = 0; i < off.channel("flags").size(); ++i) {
    differ += off.channel("flags")[i] != on.channel("flags")[i];
    if (off.channel("flags")[i] != 0) continue;
    ++explained;
    changed += off.channel("Cm")[i] != on.channel("Cm")[i];
  }
  EXPECT_EQ(differ, 0u);
  EXPECT_GT(changed, explained / 2);
  const Result bad = run_chromo("estimate " + (dir / "scene" / "MEASUREMENT.json").string() + " --out " +
                                (dir / "bad").string() + " --skin-denoise yes");
  EXPECT_NE(bad.exit_status, 0) << bad.output;
  EXPECT_NE(bad.output.find("--skin-denoise"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(dir / "bad"));
  fs::remove_all(dir);
}

TEST(RealSkinScene, BadInputIsRefusedNamingIt) {
  const fs::path dir = fresh("bad");
  Result r = run_chromo("make-real-skin-scene --out " + dir.string() + " --subjects 049-051");
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_NE(r.output.find("051"), std::string::npos) << r.output;
  r = run_chromo("make-real-skin-scene --out " + dir.string() + " --patch 2");
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_NE(r.output.find("patch_px"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir));
  r = run_chromo("discrepancy learn --out " + (dir / "r.csv").string() + " --spectra " + (dir / "missing.csv").string());
  EXPECT_EQ(r.exit_status, 2) << r.output;
}

}  // namespace
