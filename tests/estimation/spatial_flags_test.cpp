// The spatial second pass (spatial_flags.hpp): model order pooled over
// windows on synthetic frames laid out as images, and flags on the virtual
// lab's skin scene photographed through the camera model (lab_scene.hpp),
// whose region labels are the truth.
#include "chromo/estimation/spatial_flags.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>

#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/skin_refit.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "estimation_fixture.hpp"
#include "lab_scene.hpp"

namespace chromo::estimation {
namespace {

struct OrderShares {
  double before = 0, after = 0;  // share of order-4 pixels, per pixel and pooled
};

// A synthetic frame of side×side pixels (each pixel its own random skin in the
// box: the hardest case for pooling, no two neighbours alike).
OrderShares order4_shares(simulators::SyntheticOptions o, int side) {
  o.pixels = side * side;
  o.noise.noise_scale = 1.0;
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame frame = simulators::make_synthetic_frame(set, o);
  const Estimator estimator(testing::method_table(), set, EstimatorOptions{});
  std::vector<PixelEstimate> out(frame.pixels());
  const EstimateSummary summary = estimator.estimate(frame.noisy, out);
  OrderShares s;
  s.before = static_cast<double>(summary.order4) / frame.pixels();
  pool_model_order(estimator, frame.noisy, side, side, out);
  std::size_t order4 = 0;
  for (const PixelEstimate& e : out) order4 += e.order == 4;
  s.after = static_cast<double>(order4) / frame.pixels();
  std::printf("order 4: per pixel %.4f, pooled %.4f\n", s.before, s.after);
  return s;
}

simulators::SyntheticOptions skin_box(double cm_max) {
  simulators::SyntheticOptions o;
  o.low = {0.005, 0.005, 0.0, 0.0};
  o.high = {cm_max, 0.2, 1.0, 0.1};
  return o;
}

TEST(PoolModelOrder, FourDSceneGetsOrderFourOnNinetyPercent) {
  simulators::SyntheticOptions o = skin_box(0.3);
  o.low.bm = 0.1, o.high.bm = 0.4;
  o.low.che = 0.03, o.high.che = 0.08;
  const OrderShares s = order4_shares(o, 40);
  EXPECT_GE(s.after, 0.90);
}

TEST(PoolModelOrder, TwoDSceneKeepsOrderTwoOnNinetyFivePercent) {
  simulators::SyntheticOptions o = skin_box(0.3);
  o.low.bm = o.high.bm = 0.7;
  o.low.che = o.high.che = 0.0;
  const OrderShares s = order4_shares(o, 40);
  EXPECT_LE(s.after, 0.05);
}

// Pixels whose estimates differ in any field, bit for bit (NaN σ equal to NaN σ).
std::size_t different_estimates(const std::vector<PixelEstimate>& a, const std::vector<PixelEstimate>& b) {
  std::size_t different = 0;
  for (std::size_t p = 0; p < a.size(); ++p) {
    const PixelEstimate &x = a[p], &y = b[p];
    different += std::memcmp(&x.parameters, &y.parameters, sizeof x.parameters) != 0 || x.order != y.order ||
                 x.flag != y.flag || std::memcmp(&x.residual, &y.residual, sizeof(float)) != 0 ||
                 std::memcmp(&x.chi2, &y.chi2, sizeof(float)) != 0 ||
                 std::memcmp(&x.order_statistic, &y.order_statistic, sizeof(float)) != 0 ||
                 std::memcmp(x.sigma, y.sigma, sizeof x.sigma) != 0 ||
                 std::memcmp(&x.ch_che_correlation, &y.ch_che_correlation, sizeof(float)) != 0;
  }
  return different;
}

// The first pass's other-order fits (OtherOrderFit) give the pooled order the
// same estimates as its refits, bit for bit, both ways (to 4 and to 2, the
// 2D scene of the test below with the learned discrepancy, whose χ² is the
// generalised one); a stored fit of the wrong order is refused.
TEST(PoolModelOrder, StoredOtherOrderFitsEqualTheRefitsBitForBit) {
  simulators::SyntheticOptions o = skin_box(0.3);
  o.low.bm = o.high.bm = 0.7;
  o.low.che = o.high.che = 0.0;
  const int side = 48;
  o.pixels = side * side;
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame frame = simulators::make_synthetic_frame(set, o);
  EstimatorOptions options;
  options.discrepancy = ModelDiscrepancy::standard();
  const Estimator estimator(testing::method_table(), set, options);
  std::vector<PixelEstimate> refitted(frame.pixels());
  std::vector<OtherOrderFit> other(frame.pixels());
  estimator.estimate(frame.noisy, refitted, {}, {}, other);
  std::size_t stored = 0;
  for (const OtherOrderFit& f : other) stored += f.order != 0;
  EXPECT_GT(stored, frame.pixels() / 2);
  std::vector<PixelEstimate> switched = refitted;
  const NeighbourhoodSummary a = pool_model_order(estimator, frame.noisy, side, side, refitted);
  const NeighbourhoodSummary b = pool_model_order(estimator, frame.noisy, side, side, switched, {}, other);
  ASSERT_GT(a.order_to_2, 20u);
  EXPECT_EQ(a.order_to_4, b.order_to_4);
  EXPECT_EQ(a.order_to_2, b.order_to_2);
  EXPECT_EQ(different_estimates(refitted, switched), 0u);
  EXPECT_THROW(estimator.estimate_from_fit(frame.noisy.data(), OtherOrderFit{}), std::invalid_argument);
  EXPECT_THROW(pool_model_order(estimator, frame.noisy, side, side, switched, {}, std::span(other).first(3)),
               std::invalid_argument);
}

// With the multi-pixel estimate (spatial_pass with skin_denoise) the pooled
// order runs on the denoised channels: the re-fit's other-order fits replace
// the first pass's where its estimate does, and the chain's estimates equal
// those without stored fits bit for bit.
TEST(PoolModelOrder, StoredFitsFollowTheMultiPixelRefit) {
  simulators::SyntheticOptions o = skin_box(0.06);
  o.low.cm = 0.04;
  o.low.ch = 0.02, o.high.ch = 0.03;
  o.low.bm = o.high.bm = 0.7;
  o.low.che = o.high.che = 0.0;
  const int side = 40;
  o.pixels = side * side;
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame frame = simulators::make_synthetic_frame(set, o);
  const Estimator estimator(testing::method_table(), set, EstimatorOptions{});
  std::vector<PixelEstimate> refitted(frame.pixels());
  std::vector<OtherOrderFit> other(frame.pixels());
  EstimateSummary summary_a = estimator.estimate(frame.noisy, refitted, {}, {}, other);
  std::vector<PixelEstimate> switched = refitted;
  EstimateSummary summary_b = summary_a;
  NeighbourhoodOptions pool_only;
  pool_only.flags = false;
  const SpatialPass a = spatial_pass(estimator, frame.noisy, side, side, refitted, summary_a, pool_only, SkinDenoiseOptions{});
  const SpatialPass b =
      spatial_pass(estimator, frame.noisy, side, side, switched, summary_b, pool_only, SkinDenoiseOptions{}, other);
  ASSERT_TRUE(a.skin_refit && b.skin_refit);
  EXPECT_GT(a.skin_refit->refitted, frame.pixels() / 2);
  EXPECT_GT(a.skin_refit->mean_joined, 2.0);
  ASSERT_GT(a.neighbourhood.order_to_2 + a.neighbourhood.order_to_4, 20u);
  EXPECT_EQ(a.neighbourhood.order_to_2, b.neighbourhood.order_to_2);
  EXPECT_EQ(a.neighbourhood.order_to_4, b.neighbourhood.order_to_4);
  EXPECT_EQ(summary_a.order2, summary_b.order2);
  EXPECT_EQ(different_estimates(refitted, switched), 0u);
}

// The pooled order's refits on one thread and on two give the same
// estimates bit for bit (a 2D scene of which a quarter of the pixels chose
// 4 alone, so that hundreds are refitted in 2D: the parallel loop runs above
// 256 refits).
TEST(PoolModelOrder, RefitsOnTwoThreadsEqualOneThreadBitForBit) {
  simulators::SyntheticOptions o = skin_box(0.3);
  o.low.bm = o.high.bm = 0.7;
  o.low.che = o.high.che = 0.0;
  const int side = 64;
  o.pixels = side * side;
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame frame = simulators::make_synthetic_frame(set, o);
  EstimatorOptions one_thread;
  one_thread.threads = 1;
  EstimatorOptions two_threads = one_thread;
  two_threads.threads = 2;
  const Estimator serial(testing::method_table(), set, one_thread), parallel(testing::method_table(), set, two_threads);
  std::vector<PixelEstimate> a(frame.pixels());
  serial.estimate(frame.noisy, a);
  std::vector<PixelEstimate> b = a;
  const NeighbourhoodSummary sa = pool_model_order(serial, frame.noisy, side, side, a);
  const NeighbourhoodSummary sb = pool_model_order(parallel, frame.noisy, side, side, b);
  ASSERT_GT(sa.order_to_4 + sa.order_to_2, 256u);
  EXPECT_EQ(sa.order_to_4, sb.order_to_4);
  EXPECT_EQ(sa.order_to_2, sb.order_to_2);
  EXPECT_EQ(different_estimates(a, b), 0u);
}

using simulators::SceneRegion;
constexpr int kRegions = 7;

struct LabRun {
  testing::LabScene lab;
  std::vector<PixelEstimate> per_pixel, refined;
  std::size_t total[kRegions] = {}, flagged_per_pixel[kRegions] = {}, flagged[kRegions] = {};
  std::size_t clipped = 0, clipped_flagged = 0;
  // Specular pixels by added reflection: ≥ 0.03, 0.01-0.03, 0.006-0.01 (the label's edge).
  static constexpr double kBandEdges[4] = {1.0, 0.03, 0.01, 0.0};
  std::size_t band_total[3] = {}, band_flagged[3] = {};
  double band_share(int band) const { return band_total[band] ? double(band_flagged[band]) / band_total[band] : 0.0; }
  // Marker pixels by the dye's cover: ≥ 0.2, 0.1-0.2, < 0.1 (the stroke's antialiased edge).
  static constexpr double kCoverEdges[4] = {1.01, 0.2, 0.1, 0.0};
  std::size_t cover_total[3] = {}, cover_flagged[3] = {};
  double cover_share(int band) const { return cover_total[band] ? double(cover_flagged[band]) / cover_total[band] : 0.0; }
  double share(SceneRegion r, bool refined_flags = true) const {
    const int i = static_cast<int>(r);
    return total[i] ? static_cast<double>((refined_flags ? flagged : flagged_per_pixel)[i]) / total[i] : 0.0;
  }
};

LabRun run_lab(int size, double exposure_fill, const NeighbourhoodOptions& options = {}, std::uint64_t seed = 1) {
  LabRun r{testing::render_lab_scene(size, exposure_fill, seed), {}, {}};
  // Every size and exposure has the same channels' weights (the noise differs,
  // which the table's key leaves out): one table, from the tests' cache.
  const auto table = ForwardTable::load_or_build(r.lab.set, TableGrid{}, ForwardTable::default_cache_dir());
  const Estimator estimator(table, r.lab.set, EstimatorOptions{});
  r.per_pixel.resize(r.lab.measured.size() / 4);
  const std::clock_t cpu = std::clock();
  EstimateSummary summary = estimator.estimate(r.lab.measured, r.per_pixel);
  std::printf("first pass CPU %.2f s\n", double(std::clock() - cpu) / CLOCKS_PER_SEC);
  r.refined = r.per_pixel;
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t spatial_cpu = std::clock();
  refine_with_neighbourhood(estimator, r.lab.measured, r.lab.width, r.lab.height, r.refined, summary, options);
  std::printf("first pass %.2f s, spatial pass %.2f s, CPU %.2f s (printed, not asserted)\n", summary.seconds,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
              double(std::clock() - spatial_cpu) / CLOCKS_PER_SEC);
  for (std::size_t p = 0; p < r.refined.size(); ++p) {
    const int region = static_cast<int>(r.lab.region(p));
    ++r.total[region];
    r.flagged_per_pixel[region] += r.per_pixel[p].flag != PixelFlag::kExplained;
    r.flagged[region] += r.refined[p].flag != PixelFlag::kExplained;
    if (r.lab.region(p) == SceneRegion::kSpecular)
      for (int b = 0; b < 3; ++b)
        if (r.lab.added_reflection[p] >= LabRun::kBandEdges[b + 1] && r.lab.added_reflection[p] < LabRun::kBandEdges[b]) {
          ++r.band_total[b];
          r.band_flagged[b] += r.refined[p].flag != PixelFlag::kExplained;
        }
    if (r.lab.region(p) == SceneRegion::kMarker)
      for (int b = 0; b < 3; ++b)
        if (r.lab.marker_cover[p] >= LabRun::kCoverEdges[b + 1] && r.lab.marker_cover[p] < LabRun::kCoverEdges[b]) {
          ++r.cover_total[b];
          r.cover_flagged[b] += r.refined[p].flag != PixelFlag::kExplained;
        }
    if (r.lab.clipped[p]) {
      ++r.clipped;
      r.clipped_flagged += r.refined[p].flag == PixelFlag::kSaturated;
    }
  }
  std::size_t counted = 0;
  for (std::size_t c : summary.flag_counts) counted += c;
  EXPECT_EQ(counted, r.refined.size());
  for (int i = 0; i < kRegions; ++i)
    std::printf("%-12s %6zu px  flagged per pixel %.4f, with the neighbourhood %.4f\n",
                simulators::region_name(static_cast<SceneRegion>(i)), r.total[i],
                r.share(static_cast<SceneRegion>(i), false), r.share(static_cast<SceneRegion>(i)));
  std::printf("specular by added reflection: >= 0.03 %.4f (%zu px), 0.01-0.03 %.4f (%zu px), 0.006-0.01 %.4f (%zu px)\n",
              r.band_share(0), r.band_total[0], r.band_share(1), r.band_total[1], r.band_share(2), r.band_total[2]);
  std::printf("marker by the dye's cover: >= 0.2 %.4f (%zu px), 0.1-0.2 %.4f (%zu px), < 0.1 %.4f (%zu px)\n",
              r.cover_share(0), r.cover_total[0], r.cover_share(1), r.cover_total[1], r.cover_share(2), r.cover_total[2]);
  return r;
}

void expect_finite(const std::vector<PixelEstimate>& estimates) {
  for (const PixelEstimate& e : estimates)
    for (double v : {e.parameters.cm, e.parameters.ch, e.parameters.bm, e.parameters.che, double(e.residual)})
      ASSERT_TRUE(std::isfinite(v));
}

// Targets (issue 6): ≥ 95% of tattoo, marker, specular and saturated pixels
// flagged, ≤ 1% of skin, at any scale and exposure. Measured on six scenes
// (scene and camera seeds 1-6, the production readout; docs/estimation.md,
// "Flags across scale, exposure and scenes"): skin ≤ 1% holds at 512 px on
// every scene (0.06-0.16%), not below: at 256 px up to 1.74%, at 128 px up to
// 5.15% (the skin's fields vary over a few background windows there). Tattoo
// ≥ 96.3% everywhere; marker 86.9-99.3% (missed at 128 px and 256 px 0.4×:
// edge pixels with < 10-20% dye); specular 11.9-77.7% (missed: the
// highlight's weaker part looks like paler skin). The bounds below are the
// six scenes' extremes with a margin, so they hold for any of those scenes:
// regression guards, not the targets. The 5-MP session's are in
// tests/estimation/lab_flags_test.cpp.
TEST(NeighbourhoodFlags, VirtualLabSceneThroughTheCameraModel) {
  const LabRun r = run_lab(256, 0.8);
  EXPECT_LE(r.share(SceneRegion::kSkin, false), 0.0005);  // per pixel: the specular test flags no skin
  EXPECT_LE(r.share(SceneRegion::kSkin), 0.015);            // six scenes: 0.10-1.24%
  EXPECT_GE(r.share(SceneRegion::kTattoo), 0.95);           // 98.9-99.7%
  EXPECT_GE(r.share(SceneRegion::kMarker), 0.94);           // 94.9-96.5%
  EXPECT_GE(r.share(SceneRegion::kSpecular), 0.38);         // 40.4-52.3%
  EXPECT_GE(r.share(SceneRegion::kSpecular), r.share(SceneRegion::kSpecular, false) + 0.15);
  EXPECT_EQ(r.share(SceneRegion::kWhiteTarget), 1.0);
  expect_finite(r.refined);
}

// Step 4b of the pass: an edge pixel of the marker's stroke, part dye and part
// skin, deviates from its background along the dye's own deviation; the
// one-sided test along that direction, beside pixels flagged before the pass,
// flags edge pixels the 4-channel χ² test leaves (the white test's twin).
// Skin beside the same stroke has no such deviation and stays explained.
// Measured on six scenes at 256 px 1× (the same estimate with the test off
// and on): edge pixels with 10-20% dye 107 → 119 of 160 flagged (66.9% →
// 74.4%; +1 to +4 of 26-27 per scene), the marker +1 to +4 pixels, skin and
// specular unchanged to 0.01%.
TEST(NeighbourhoodFlags, PartialCoverBesideFlaggedMaterialJoins) {
  NeighbourhoodOptions without;
  without.grow_mixtures = false;
  const LabRun before = run_lab(256, 0.8, without), after = run_lab(256, 0.8);
  EXPECT_GE(after.cover_share(0), before.cover_share(0));
  EXPECT_GT(after.cover_flagged[1], before.cover_flagged[1]);
  EXPECT_GT(after.flagged[static_cast<int>(SceneRegion::kMarker)], before.flagged[static_cast<int>(SceneRegion::kMarker)]);
  EXPECT_LE(after.share(SceneRegion::kSkin), before.share(SceneRegion::kSkin) + 0.0005);
  EXPECT_EQ(after.share(SceneRegion::kSpecular), before.share(SceneRegion::kSpecular));
}

// Half the scale at 2.5× the exposure: the skin's fields vary over a few
// background windows and the noise is lower, so the quadratic background's
// own misfit exceeds the noise (21-30% of the skin was flagged when the
// statistic counted noise alone; on six scenes now 0.22-5.15%: the 1% target
// is not met at this size); the highlight's core and the white target clip.
TEST(NeighbourhoodFlags, SmallBrightSceneKeepsSkinAndFlagsClippedPixels) {
  const LabRun r = run_lab(128, 2.0);
  EXPECT_LE(r.share(SceneRegion::kSkin), 0.06);        // six scenes: 0.22-5.15%
  EXPECT_GE(r.share(SceneRegion::kTattoo), 0.95);      // 98.3-99.2%
  EXPECT_GE(r.share(SceneRegion::kMarker), 0.92);      // 93.5-96.9%
  EXPECT_GE(r.share(SceneRegion::kSpecular), 0.62);    // 65.3-77.7%
  ASSERT_GT(r.clipped, 100u);
  EXPECT_EQ(r.clipped_flagged, r.clipped);
  expect_finite(r.refined);
}

// The rest of the 128-512 px × 0.5-2.5× exposure grid (the two runs above are
// its other points). Skin: ≤ 1% at 512 px (the target; six scenes
// 0.06-0.16%), ≤ 2% at 256 px (0.11-1.74%), ≤ 6% at 128 px (0.11-5.14%);
// tattoo ≥ 95% everywhere (96.3-99.95%). The printed shares per region are
// the figures in docs/estimation.md (~40 s).
TEST(NeighbourhoodFlags, SkinFlaggedShareAcrossScaleAndExposure) {
  for (int size : {128, 256, 512})
    for (double fill : {0.4, 0.8, 2.0}) {
      if ((size == 256 && fill == 0.8) || (size == 128 && fill == 2.0)) continue;  // the two tests above
      std::printf("== %d px, exposure fill %.1f\n", size, fill);
      const LabRun r = run_lab(size, fill);
      const double skin_bound = size >= 512 ? 0.01 : size >= 256 ? 0.02 : 0.06;
      EXPECT_LE(r.share(SceneRegion::kSkin), skin_bound) << size << " px, fill " << fill;
      EXPECT_GE(r.share(SceneRegion::kTattoo), 0.95) << size << " px, fill " << fill;
      expect_finite(r.refined);
    }
}

// The level the flag pass runs on: the cells up to 512 px (the tuned range),
// blocks of round(longer side / 256) above; an explicit block_px wins.
TEST(NeighbourhoodFlags, BlockSizeFollowsTheImageSize) {
  const NeighbourhoodOptions o;
  EXPECT_EQ(neighbourhood_block_px(128, 128, o), 1);
  EXPECT_EQ(neighbourhood_block_px(512, 384, o), 1);
  EXPECT_EQ(neighbourhood_block_px(1296, 972, o), 5);  // the 5-MP session's cells
  EXPECT_EQ(neighbourhood_block_px(972, 1296, o), 5);
  EXPECT_EQ(neighbourhood_block_px(2592, 1944, o), 10);
  NeighbourhoodOptions fixed;
  fixed.block_px = 3;
  EXPECT_EQ(neighbourhood_block_px(128, 128, fixed), 3);
  fixed.block_px = -1;
  std::string error;
  EXPECT_FALSE(fixed.IsValid(&error));
  EXPECT_NE(error.find("block_px"), std::string::npos);
}

// Whatever the input (NaN, ±inf, negative, huge, constant), both passes end
// without NaN in the maps.
TEST(NeighbourhoodFlags, AnyInputGivesFiniteMaps) {
  const MeasurementSet set = testing::method_set();
  const Estimator estimator(testing::method_table(), set, EstimatorOptions{});
  const int width = 48, height = 40, channels = set.size();
  std::vector<float> measured(static_cast<std::size_t>(width) * height * channels);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.5f, 2.0f);
  const float specials[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(), -1.0f, 0.0f, 1e30f, 0.3f};
  for (std::size_t i = 0; i < measured.size(); ++i) measured[i] = (i / channels) % 5 == 0 ? specials[rng() % 7] : u(rng);
  std::vector<PixelEstimate> out(static_cast<std::size_t>(width) * height);
  for (int block : {1, 3}) {  // on the pixels, and on 3×3 blocks (partial ones at the right and bottom)
    EstimateSummary summary = estimator.estimate(measured, out);
    NeighbourhoodOptions o;
    o.block_px = block;
    EXPECT_EQ(refine_with_neighbourhood(estimator, measured, width, height, out, summary, o).block_px, block);
    for (const PixelEstimate& e : out)
      for (double v : {e.parameters.cm, e.parameters.ch, e.parameters.bm, e.parameters.che, double(e.residual)})
        ASSERT_TRUE(std::isfinite(v));
  }
  // A constant image: nothing deviates from its neighbourhood.
  std::fill(measured.begin(), measured.end(), 0.3f);
  estimator.estimate(measured, out);
  const NeighbourhoodSummary s = refine_flags_with_neighbourhood(estimator, measured, width, height, out);
  EXPECT_EQ(s.flagged_touching + s.flagged_holes, 0u);
  EXPECT_THROW(refine_flags_with_neighbourhood(estimator, measured, width + 1, height, out), std::invalid_argument);
  NeighbourhoodOptions bad;
  bad.significance = 0;
  EXPECT_THROW(refine_flags_with_neighbourhood(estimator, measured, width, height, out, bad), std::invalid_argument);
  NeighbourhoodOptions two_sided;
  two_sided.mixture_significance = 0.5;  // the partial-cover test is one-sided: α < 0.5
  std::string error;
  EXPECT_FALSE(two_sided.IsValid(&error));
  EXPECT_NE(error.find("mixture_significance"), std::string::npos);
}

}  // namespace
}  // namespace chromo::estimation
