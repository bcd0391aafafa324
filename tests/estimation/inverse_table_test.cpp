#include "chromo/estimation/inverse_table.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <vector>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/inverter.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "estimation_fixture.hpp"

namespace chromo::estimation {
namespace {

namespace fs = std::filesystem;

std::shared_ptr<const InverseTable> method_inverse_table() {
  return InverseTable::load_or_build(testing::method_table(), ForwardTable::default_cache_dir());
}

// A pixel's 4 measured values (from `values` at pixel i, the blue-only
// channel scaled by blue_scale) and its weights as the Estimator gives them:
// camera noise plus 0.3% model error.
struct WeightedPixel {
  double m[4], w[4];
};
WeightedPixel weighted_pixel(const MeasurementSet& set, const std::vector<float>& values, std::size_t i,
                             double blue_scale = 1.0) {
  WeightedPixel p;
  for (int c = 0; c < 4; ++c) {
    p.m[c] = values[i * 4 + c] * (c == 3 ? blue_scale : 1.0);
    p.w[c] = set.channels[c].noise.fit_weight(p.m[c], EstimatorOptions{}.model_sigma_relative);
  }
  return p;
}

// `pixels` random in-gamut skin pixels of `set` (synthetic.hpp), noisy with
// the camera noise model's σ × noise_scale (which becomes set's noise).
simulators::SyntheticFrame skin_frame(MeasurementSet& set, int pixels, std::uint64_t seed, double noise_scale = 1.0) {
  simulators::SyntheticOptions o;
  o.pixels = pixels;
  o.seed = seed;
  o.noise.noise_scale = noise_scale;
  return simulators::make_synthetic_frame(set, o);
}

double mean_d65_delta_e(const ForwardTable& table, const std::vector<GridPoint>& a, const std::vector<GridPoint>& b) {
  const SkinModel model;
  const spectral::Spectrum& d65 = spectral::illuminant_d65();
  const spectral::Xyz white = spectral::white_point(d65);
  double sum = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto lab = [&](const GridPoint& x) {
      return spectral::lab_from_xyz(spectral::xyz_of_reflectance(model.albedo(table.from_grid(x)), d65), white);
    };
    sum += spectral::delta_e94(lab(a[i]), lab(b[i]));
  }
  return sum / a.size();
}

// In-gamut skin, noise-free and with the camera noise model: the pre-solved
// path explains almost every pixel itself, noise-free it reaches the
// exhaustive search's χ² (noisy, a fifth of the pixels stop in another
// bounded local minimum below the acceptance χ²), and the relit colour under
// D65 stays within a few hundredths of ΔE94 of the exhaustive search's (the
// issue's bound: 0.1).
TEST(FastInverter, PresolvedPathMatchesTheExhaustiveSearchOnInGamutSkin) {
  const auto table = testing::method_table();
  const FastInverter fast(table, method_inverse_table());
  const ExhaustiveInverter exhaustive(table);
  for (const double noise : {0.0, 1.0}) {
    MeasurementSet set = testing::method_set();
    const simulators::SyntheticFrame f = skin_frame(set, 300, 21, noise);
    int presolved = 0, close = 0;
    std::vector<GridPoint> fast_x, exhaustive_x;
    for (std::size_t i = 0; i < f.pixels(); ++i) {
      const auto [m, w] = weighted_pixel(set, noise > 0 ? f.noisy : f.clean, i);
      FastPath path;
      const Fit a = fast.fit(m, w, 4, &path), b = exhaustive.fit(m, w, 4);
      presolved += path == FastPath::kPresolved;
      close += a.chi2 <= b.chi2 + 0.05;  // noisy: pixels off the gamut's thin sheet end on a bounded face, where
                                         // several local minima compete
      fast_x.push_back(a.x), exhaustive_x.push_back(b.x);
    }
    SCOPED_TRACE(noise);
    EXPECT_GE(presolved, noise > 0 ? 255 : 291);  // ≥ 85% noisy (89% here, bench 91%), ≥ 97% noise-free (99.7%)
    EXPECT_GE(close, noise > 0 ? 225 : 291);      // at the exhaustive χ²: ≥ 75% noisy (79%), ≥ 97% noise-free
    EXPECT_LT(mean_d65_delta_e(*table, fast_x, exhaustive_x), noise > 0 ? 0.1 : 0.03);
  }
}

// Chord steps (the cell's stored J⁺ again from the current point) replace
// Gauss-Newton iterations on noise-free skin: a pixel they finish (no
// Gauss-Newton iteration) is explained to within the convergence χ², lands
// mostly within a tenth of a node of the Gauss-Newton-only fit in Cm (the
// rest is the valley along which the four channels barely change) and
// relights under D65 within a few hundredths of ΔE94 of the exhaustive
// search's fit (0.035 here); with them the fits need fewer Gauss-Newton
// iterations (an operation count, not a clock).
TEST(FastInverter, ChordStepsFinishMostNoiseFreePixelsWithoutGaussNewton) {
  const auto table = testing::method_table();
  FastInverterOptions no_chord;
  no_chord.chord_steps = 0;
  const FastInverter fast(table, method_inverse_table()), newton_only(table, method_inverse_table(), no_chord);
  const ExhaustiveInverter exhaustive(table);
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame f = skin_frame(set, 300, 23);
  int chord_only = 0, close_cm = 0, chord_iterations = 0, newton_iterations = 0;
  std::vector<GridPoint> chord_x, exhaustive_x;
  for (std::size_t i = 0; i < f.pixels(); ++i) {
    const auto [m, w] = weighted_pixel(set, f.clean, i);
    FastPath path;
    const Fit a = fast.fit(m, w, 4, &path), b = newton_only.fit(m, w, 4);
    chord_iterations += a.iterations, newton_iterations += b.iterations;
    if (path != FastPath::kPresolved || a.iterations > 0) continue;
    ++chord_only;
    EXPECT_LE(a.chi2, fast.options().converged_chi2);
    close_cm += std::abs(a.x[0] - b.x[0]) <= 0.1;
    chord_x.push_back(a.x), exhaustive_x.push_back(exhaustive.fit(m, w, 4).x);
  }
  EXPECT_GE(chord_only, 120);  // 40%; about half in the bench
  EXPECT_GE(close_cm, chord_only * 9 / 10);
  EXPECT_LT(chord_iterations, newton_iterations * 3 / 4);
  EXPECT_LT(mean_d65_delta_e(*table, chord_x, exhaustive_x), 0.05);
}

// Noisy pixels off the gamut's thin sheet, pushed further out along the
// blue-only channel: the fit ends on a bound face with a finite χ² and
// grid coordinates inside the table, whatever the chord and Gauss-Newton
// settings.
TEST(FastInverter, NoisyPixelsOnABoundFaceGetAFiniteBoundedFit) {
  const auto table = testing::method_table();
  const auto n = table->nodes();
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame f = skin_frame(set, 200, 25, 2);
  for (const int chord_steps : {0, 3, 50}) {
    FastInverterOptions options;
    options.chord_steps = chord_steps;
    const FastInverter fast(table, method_inverse_table(), options);
    int on_face = 0;
    for (std::size_t i = 0; i < f.pixels(); ++i) {
      const auto [m, w] = weighted_pixel(set, f.noisy, i, 1.15);
      const Fit fit = fast.fit(m, w, 4);
      ASSERT_TRUE(std::isfinite(fit.chi2));
      bool at_bound = false;
      for (int k = 0; k < 4; ++k) {
        ASSERT_TRUE(fit.x[k] >= 0 && fit.x[k] <= n[k] - 1) << "pixel " << i << " axis " << k << ": " << fit.x[k];
        at_bound = at_bound || fit.x[k] == 0 || fit.x[k] == n[k] - 1;
      }
      on_face += at_bound && fit.chi2 > 0.1;
    }
    EXPECT_GT(on_face, 20) << "chord_steps " << chord_steps;  // the case the test is about occurs
  }
}

// On a bound face with an acceptable χ² Gauss-Newton stops once a step
// gains less than face_stall_relative of χ²: fewer iterations for noisy
// pixels, and the same acceptance (no pixel crosses presolved_accept_chi2,
// so none newly takes the search path) at nearly the same χ².
TEST(FastInverter, FaceStallSavesIterationsOnNoisyPixels) {
  const auto table = testing::method_table();
  FastInverterOptions crawl;
  crawl.face_stall_relative = 0;
  const FastInverter fast(table, method_inverse_table()), crawling(table, method_inverse_table(), crawl);
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame f = skin_frame(set, 400, 27);
  int iterations = 0, crawl_iterations = 0, same_path = 0;
  double chi2 = 0, crawl_chi2 = 0;
  for (std::size_t i = 0; i < f.pixels(); ++i) {
    const auto [m, w] = weighted_pixel(set, f.noisy, i);
    FastPath path, crawl_path;
    const Fit a = fast.fit(m, w, 4, &path), b = crawling.fit(m, w, 4, &crawl_path);
    iterations += a.iterations, crawl_iterations += b.iterations;
    chi2 += a.chi2, crawl_chi2 += b.chi2;
    same_path += path == crawl_path;
  }
  EXPECT_LT(iterations, crawl_iterations * 9 / 10);
  EXPECT_LT(chi2, crawl_chi2 * 1.05);
  EXPECT_GE(same_path, static_cast<int>(f.pixels()) - 2);
}

TEST(FastInverter, OptionsAreValidated) {
  std::string error;
  EXPECT_TRUE(FastInverterOptions{}.IsValid(&error));
  FastInverterOptions bad;
  bad.chord_steps = -1;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(error.find("chord_steps"), std::string::npos);
  bad = {};
  bad.converged_chi2 = bad.presolved_accept_chi2 + 1;  // above the acceptance χ²
  EXPECT_FALSE(bad.IsValid(&error));
  bad = {};
  bad.face_stall_relative = 1;
  EXPECT_FALSE(bad.IsValid(&error));
  bad = {};
  bad.newton_steps = -2;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_THROW(FastInverter(testing::method_table(), method_inverse_table(), bad), std::invalid_argument);
  EstimatorOptions estimator;
  estimator.fast.converged_chi2 = -1;
  EXPECT_FALSE(estimator.IsValid(&error));
  EXPECT_NE(error.find("fast: converged_chi2"), std::string::npos);
}

// The non-unique inverse: cells with several branches exist, and a
// measurement at any branch's stored solution is fitted to within the
// convergence χ² (0.1σ per channel) by the pre-solved path (whichever branch
// it picks explains it).
// fit() is its two public paths combined (the bench's cost breakdown times
// them apart): the pre-solved fit when it converged within the acceptance
// χ², else the smaller χ² of it and the search path. Noise-free skin falls
// mostly in inverse-table cells that hold table nodes themselves; noisy skin
// lies off the gamut's thin sheet, mostly in empty cells that point at a
// neighbour (synthetic: 14% and 92%).
TEST(FastInverter, FitIsThePresolvedPathThenTheSearchPath) {
  const auto table = testing::method_table();
  const FastInverter fast(table, method_inverse_table());
  for (const double noise : {0.0, 1.0}) {
    MeasurementSet set = testing::method_set();
    const simulators::SyntheticFrame f = skin_frame(set, 300, 23, noise);
    int occupied = 0, searched = 0;
    for (std::size_t i = 0; i < f.pixels(); ++i) {
      const auto [m, w] = weighted_pixel(set, noise > 0 ? f.noisy : f.clean, i);
      FastPath path;
      const Fit fit = fast.fit(m, w, 4, &path);
      Fit presolved;
      const bool converged = fast.fit_presolved(m, w, presolved);
      if (converged && presolved.chi2 <= fast.options().presolved_accept_chi2) {
        EXPECT_EQ(path, FastPath::kPresolved);
        EXPECT_EQ(fit.chi2, presolved.chi2);
        EXPECT_EQ(fit.x, presolved.x);
      } else {
        ++searched;
        EXPECT_EQ(path, FastPath::kSearched);
        EXPECT_EQ(fit.chi2, std::min(presolved.chi2, fast.fit_by_search(m, w, 4).chi2));
      }
      occupied += fast.in_occupied_cell(m);
    }
    SCOPED_TRACE(noise);
    if (noise > 0) {
      EXPECT_LT(occupied, 60);  // ≤ 20% (8% in the bench)
      EXPECT_GT(searched, 1);   // the search path runs (1% here, 4% of the lab's noisy skin)
    } else {
      EXPECT_GT(occupied, 225);  // ≥ 75% (86% in the bench)
    }
  }
  // A table node's own prediction lies in its own, occupied cell.
  const auto n = table->nodes();
  for (int i = 0; i < 50; ++i) {
    const float* v = table->node(i % n[0], (7 * i) % n[1], (3 * i) % n[2], i % n[3]);
    const double m[4] = {v[0], v[1], v[2], v[3]};
    EXPECT_TRUE(fast.in_occupied_cell(m));
  }
  const double nan_pixel[4] = {NAN, 0.2, 0.2, 0.2};
  EXPECT_FALSE(fast.in_occupied_cell(nan_pixel));
}

// The Estimator caps the pre-solved acceptance χ² at its own 4D flag
// threshold (10.83 for four channels at 0.001): the search path runs where
// the pre-solved fit would be flagged, not below that. Noisy pixels whose
// pre-solved fit converges between χ² 4 (the previous acceptance) and the
// threshold keep that fit, which the flag test passes; an inverter accepting
// up to 4 searches most of them.
TEST(FastInverter, TheEstimatorSearchesOnlyWhereThePresolvedFitWouldBeFlagged) {
  const auto table = testing::method_table();
  const MeasurementSet method_set = testing::method_set();
  const Estimator estimator(table, method_set, EstimatorOptions{});
  const auto& fast = static_cast<const FastInverter&>(estimator.inverter());
  EXPECT_NEAR(estimator.flag_threshold(4), 10.83, 0.01);
  EXPECT_EQ(fast.options().presolved_accept_chi2, estimator.flag_threshold(4));
  EstimatorOptions stricter;
  stricter.flag_significance = 0.01, stricter.fast.presolved_accept_chi2 = 100;
  const Estimator capped(table, method_set, stricter);
  EXPECT_NEAR(capped.flag_threshold(4), 6.63, 0.01);
  EXPECT_EQ(static_cast<const FastInverter&>(capped.inverter()).options().presolved_accept_chi2,
            capped.flag_threshold(4));

  FastInverterOptions accept_4;
  accept_4.presolved_accept_chi2 = 4;
  const FastInverter previous(table, method_inverse_table(), accept_4);
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame f = skin_frame(set, 400, 31, 1.0);
  int in_band = 0, previous_searched = 0;
  for (std::size_t i = 0; i < f.pixels(); ++i) {
    const auto [m, w] = weighted_pixel(set, f.noisy, i);
    Fit presolved;
    const bool converged = fast.fit_presolved(m, w, presolved);
    if (!converged || presolved.chi2 <= 4 || presolved.chi2 > estimator.flag_threshold(4)) continue;
    ++in_band;
    FastPath path, previous_path;
    const Fit fit = fast.fit(m, w, 4, &path);
    previous.fit(m, w, 4, &previous_path);
    EXPECT_EQ(path, FastPath::kPresolved);
    EXPECT_EQ(fit.chi2, presolved.chi2);
    // (The acceptance also steers the pre-solved path itself, so the
    // previous inverter's own pre-solved fit may end below 4.)
    previous_searched += previous_path == FastPath::kSearched;
    const PixelEstimate e = estimator.estimate_pixel(f.noisy.data() + i * 4, ModelChoice::k4d);
    EXPECT_EQ(e.flag, PixelFlag::kExplained);
  }
  EXPECT_GE(in_band, 3);  // the band is exercised (≈ 3% of the lab's noisy skin)
  EXPECT_GE(2 * previous_searched, in_band);
}

// search_fallback = false (fast_budget_bench's cheaper budgets): every pixel
// whose key cell holds a branch ends on the pre-solved path, with its best point even
// where the default would have searched; with no chord or Newton step that
// point is a branch's linear step (no iteration).
TEST(FastInverter, WithoutTheSearchFallbackThePresolvedPathAnswers) {
  const auto table = testing::method_table();
  // Both accept up to χ² 4 (searching more pixels than the default 10.83).
  FastInverterOptions searching, linear_only;
  searching.presolved_accept_chi2 = linear_only.presolved_accept_chi2 = 4;
  linear_only.search_fallback = false, linear_only.newton_steps = 0, linear_only.chord_steps = 0;
  const FastInverter fast(table, method_inverse_table(), searching), cheap(table, method_inverse_table(), linear_only);
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame f = skin_frame(set, 300, 29, 1.0);
  int would_search = 0, unacceptable = 0;
  for (std::size_t i = 0; i < f.pixels(); ++i) {
    const auto [m, w] = weighted_pixel(set, f.noisy, i);
    FastPath default_path, path;
    fast.fit(m, w, 4, &default_path);
    const Fit fit = cheap.fit(m, w, 4, &path);
    would_search += default_path == FastPath::kSearched;
    EXPECT_EQ(path, FastPath::kPresolved);
    EXPECT_EQ(fit.iterations, 0);
    unacceptable += fit.chi2 > linear_only.presolved_accept_chi2;
    Fit presolved;
    cheap.fit_presolved(m, w, presolved);
    EXPECT_EQ(fit.x, presolved.x);
    for (double x : fit.x) EXPECT_TRUE(std::isfinite(x));
  }
  EXPECT_GT(would_search, 5);   // the search fallback runs on some of these pixels…
  EXPECT_GT(unacceptable, 20);  // …and the linear step alone leaves many above the acceptance χ²
}

// Tattoo ink and marker fall outside the inverse table's reach (no cell):
// the search path seeds from the two-level coarse node scan, and ends at the
// exhaustive search's minimum, or close to it: a cheaper seed must not leave
// such a pixel in a worse local minimum (its flag code, 5 or 6, and the fit
// shown for inspection come from it).
TEST(FastInverter, OutsideTheInverseTableTheSearchFindsTheExhaustiveMinimum) {
  const auto table = testing::method_table();
  const FastInverter fast(table, method_inverse_table());
  const ExhaustiveInverter exhaustive(table);
  MeasurementSet set = testing::method_set();
  simulators::SyntheticOptions o;
  o.pixels = 600, o.seed = 31;
  o.share[static_cast<int>(simulators::SyntheticKind::kTattoo)] = 0.5, o.share[static_cast<int>(simulators::SyntheticKind::kMarker)] = 0.5;
  const simulators::SyntheticFrame f = simulators::make_synthetic_frame(set, o);
  int outside = 0, as_good = 0, close = 0;
  for (std::size_t i = 0; i < f.pixels() && outside < 80; ++i) {
    const auto [m, w] = weighted_pixel(set, f.noisy, i);
    const float mf[4] = {float(m[0]), float(m[1]), float(m[2]), float(m[3])};
    if (!std::isfinite(m[0] + m[1] + m[2] + m[3]) || fast.inverse_table().cell_of(mf) != InverseTable::kNoCell) continue;
    ++outside;
    const double searched = fast.fit(m, w, 4).chi2, reference = exhaustive.fit(m, w, 4).chi2;
    as_good += searched <= reference * 1.001 + 1e-9;
    close += searched <= reference * 1.05 + 1e-9;
  }
  ASSERT_GE(outside, 40);
  EXPECT_GE(as_good, outside * 8 / 10);
  EXPECT_GE(close, outside * 95 / 100);
}

TEST(InverseTable, EveryStoredBranchIsFittedExactly) {
  const auto table = testing::method_table();
  const auto inverse = method_inverse_table();
  const FastInverter fast(table, inverse);
  const InverseTable::Cell& last = inverse->cell(static_cast<std::uint32_t>(inverse->occupied_cells() - 1));
  EXPECT_GT(last.branch_begin + last.branch_count, inverse->occupied_cells());  // some cells hold more than one branch
  const std::vector<double> w(4, 100.0);
  int multi = 0, exact = 0, presolved = 0;
  for (std::size_t cell = 0; cell < inverse->occupied_cells() && multi < 200; cell += 7) {
    const InverseTable::Cell& c = inverse->cell(static_cast<std::uint32_t>(cell));
    if (c.branch_count < 2) continue;
    ++multi;
    const InverseTable::Branch& b = inverse->branches(c)[c.branch_count - 1];  // not the best branch at the centre
    double m[4];
    table->predict({b.x0[0], b.x0[1], b.x0[2], b.x0[3]}, m);
    FastPath path;
    const Fit f = fast.fit(m, w.data(), 4, &path);
    exact += f.chi2 <= FastInverterOptions{}.converged_chi2;
    presolved += path == FastPath::kPresolved;
  }
  ASSERT_EQ(multi, 200);
  EXPECT_GE(exact, 198);
  EXPECT_GE(presolved, 190);
}

// Every cell holds the 2D model's pre-solved fit: on the slice (βm = 0.7,
// Che = 0) with a linear step that never leaves it. A 2D-model scene's 2D
// fit then starts there: it takes the pre-solved path on almost every pixel,
// reaches the exhaustive slice search's χ² (the 2D inverter) and relights
// under D65 as it does; with Options::presolved_slice off the same pixels
// take the search path.
TEST(FastInverter, TheTwoDFitStartsFromThePresolvedSliceFit) {
  const auto table = testing::method_table();
  const auto inverse = method_inverse_table();
  const FastInverter fast(table, inverse);
  FastInverterOptions search_only;
  search_only.presolved_slice = false;
  const FastInverter searched(table, inverse, search_only);
  const TwoDInverter two_d(table);
  std::size_t with_slice = 0;
  for (std::uint32_t cell = 0; cell < inverse->occupied_cells() + inverse->presolved_empty_cells(); ++cell) {
    const std::uint32_t index = inverse->cell(cell).slice_branch;
    if (index == InverseTable::kNoCell) continue;
    ++with_slice;
    const InverseTable::Branch& b = inverse->branch(index);
    ASSERT_NEAR(b.x0[2], fast.bm_2d_coordinate(), 1e-5);
    ASSERT_EQ(b.x0[3], 0.0f);
    for (int c = 0; c < 4; ++c) {
      ASSERT_EQ(b.jinv[2 * 4 + c], 0.0f);
      ASSERT_EQ(b.jinv[3 * 4 + c], 0.0f);
    }
  }
  EXPECT_GE(with_slice, (inverse->occupied_cells() + inverse->presolved_empty_cells()) * 99 / 100);
  for (const double noise : {0.0, 1.0}) {
    MeasurementSet set = testing::method_set();
    simulators::SyntheticOptions o;
    o.pixels = 300;
    o.seed = 27;
    o.noise.noise_scale = noise;
    o.low.bm = o.high.bm = 0.7;
    o.low.che = o.high.che = 0;
    const simulators::SyntheticFrame f = simulators::make_synthetic_frame(set, o);
    int presolved = 0, close = 0, search_path = 0;
    std::vector<GridPoint> fast_x, reference_x;
    for (std::size_t i = 0; i < f.pixels(); ++i) {
      const auto [m, w] = weighted_pixel(set, noise > 0 ? f.noisy : f.clean, i);
      FastPath path, old_path;
      const Fit a = fast.fit(m, w, 2, &path), b = two_d.fit(m, w, 2);
      searched.fit(m, w, 2, &old_path);
      presolved += path == FastPath::kPresolved;
      search_path += old_path == FastPath::kSearched;
      close += a.chi2 <= b.chi2 + 0.05;
      EXPECT_NEAR(a.x[2], fast.bm_2d_coordinate(), 1e-5);
      EXPECT_EQ(a.x[3], 0.0);
      fast_x.push_back(a.x), reference_x.push_back(b.x);
    }
    SCOPED_TRACE(noise);
    EXPECT_EQ(search_path, 300);
    EXPECT_GE(presolved, 291);  // 97% (all here)
    EXPECT_GE(close, 291);      // 97% (all here; the search path 98% noisy)
    EXPECT_LT(mean_d65_delta_e(*table, fast_x, reference_x), noise > 0 ? 0.02 : 0.005);  // 0.0062, 0.0019 here
  }
}

// The inverse table's build settings: validated, the noise ratios rounded to
// half-octaves of the smallest (sessions whose noise differs a little share a
// cached table), and part of the cache key.
TEST(InverseTable, SettingsAreValidatedQuantisedAndPartOfTheKey) {
  const auto table = testing::method_table();
  std::string error;
  InverseTableSettings equal;
  EXPECT_TRUE(equal.IsValid(&error));
  EXPECT_EQ(equal.quantised_sigma(), (std::array<double, 4>{1, 1, 1, 1}));
  InverseTableSettings lab;  // the virtual lab's σ/value: the blue-only difference channel ≈ 10× the others
  lab.relative_sigma = {0.03, 0.02, 0.033, 0.25};
  EXPECT_TRUE(lab.IsValid(&error));
  const std::array<double, 4> q = lab.quantised_sigma();
  EXPECT_DOUBLE_EQ(q[0], std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(q[1], 1);
  EXPECT_DOUBLE_EQ(q[2], std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(q[3], std::exp2(3.5));
  InverseTableSettings near = lab, scaled = lab, off = lab;
  near.relative_sigma[3] = 0.26;
  for (double& v : scaled.relative_sigma) v *= 3;
  off.presolve_empty_cells = false;
  EXPECT_EQ(InverseTable::cache_key(*table, near), InverseTable::cache_key(*table, lab));
  EXPECT_EQ(InverseTable::cache_key(*table, scaled), InverseTable::cache_key(*table, lab));
  EXPECT_NE(InverseTable::cache_key(*table, lab), InverseTable::cache_key(*table, equal));
  EXPECT_NE(InverseTable::cache_key(*table, off), InverseTable::cache_key(*table, lab));

  for (const std::array<double, 4>& bad : {std::array<double, 4>{-1, 1, 1, 1}, std::array<double, 4>{NAN, 1, 1, 1},
                                            std::array<double, 4>{0, 1, 1, 1}, std::array<double, 4>{INFINITY, 1, 1, 1}}) {
    InverseTableSettings s;
    s.relative_sigma = bad;
    EXPECT_FALSE(s.IsValid(&error));
    EXPECT_NE(error.find("relative_sigma"), std::string::npos);
    EXPECT_THROW(InverseTable::cache_key(*table, s), std::invalid_argument);
    FastInverterOptions options;
    options.inverse_table = s;
    EXPECT_FALSE(options.IsValid(&error));
    EXPECT_NE(error.find("inverse_table: relative_sigma"), std::string::npos) << error;
  }
  // From a set's noise models: σ/value at albedo 0.2 per channel.
  const MeasurementSet set = testing::method_set();
  const std::array<double, 4> sigma = InverseTableSettings::from_noise(set);
  for (int c = 0; c < 4; ++c) EXPECT_DOUBLE_EQ(sigma[c], std::sqrt(set.channels[c].noise.variance(0.2)) / 0.2);
}

// Empty cells hold their own branch: the bounded fit at their block's
// centre, on a bound face for many of them, where the held coordinates'
// rows of J⁺ are zero (the linear step stays on the face) — and only there.
TEST(InverseTable, EmptyCellsHoldTheirOwnBoundedFit) {
  const auto table = testing::method_table();
  const auto inverse = method_inverse_table();
  ASSERT_GT(inverse->presolved_empty_cells(), 2 * inverse->occupied_cells());
  const auto n = table->nodes();
  int on_face = 0, checked = 0;
  for (std::size_t cell = inverse->occupied_cells(); cell < inverse->occupied_cells() + inverse->presolved_empty_cells();
       cell += 97, ++checked) {
    const InverseTable::Cell& c = inverse->cell(static_cast<std::uint32_t>(cell));
    ASSERT_NE(c.presolved_branch, InverseTable::kNoCell);
    const InverseTable::Branch& b = inverse->branch(c.presolved_branch);
    double m0[4], jacobian[16];
    table->predict({b.x0[0], b.x0[1], b.x0[2], b.x0[3]}, m0, jacobian);
    bool held = false;
    for (int k = 0; k < 4; ++k) {
      ASSERT_TRUE(b.x0[k] >= 0 && b.x0[k] <= n[k] - 1);
      const bool zero_row = b.jinv[k * 4] == 0 && b.jinv[k * 4 + 1] == 0 && b.jinv[k * 4 + 2] == 0 && b.jinv[k * 4 + 3] == 0;
      const bool at_bound = b.x0[k] == 0 || b.x0[k] == n[k] - 1;
      const double column = std::abs(jacobian[k]) + std::abs(jacobian[4 + k]) + std::abs(jacobian[8 + k]) + std::abs(jacobian[12 + k]);
      // A zero row: a held coordinate, or one the channels do not see at all there.
      if (zero_row) {
        EXPECT_TRUE(at_bound || column < 1e-9) << "cell " << cell << " axis " << k << " column " << column;
      }
      held = held || (zero_row && at_bound);
    }
    on_face += held;
  }
  EXPECT_GT(on_face, checked / 8);  // the case the branches are for occurs (18%)
}

// Noisy skin falls mostly in empty cells. Starting from their own bounded
// fit (its face and fold) instead of only the neighbour's branches, it needs
// fewer Gauss-Newton iterations, goes to the search path no more often and
// ends at no larger χ²; noise-free skin is fitted as well as before.
TEST(FastInverter, PresolvedEmptyCellsSaveNoisyPixelsIterations) {
  const auto table = testing::method_table();
  InverseTableSettings off;
  off.presolve_empty_cells = false;
  const FastInverter fast(table, method_inverse_table()),
      plain(table, InverseTable::load_or_build(table, ForwardTable::default_cache_dir(), nullptr, nullptr, 0, off));
  EXPECT_EQ(plain.inverse_table().presolved_empty_cells(), 0u);
  for (const double noise : {1.0, 0.0}) {
    MeasurementSet set = testing::method_set();
    const simulators::SyntheticFrame f = skin_frame(set, 600, 31, noise);
    int iterations[2] = {}, searched[2] = {};
    double chi2[2] = {};
    for (std::size_t i = 0; i < f.pixels(); ++i) {
      const WeightedPixel p = weighted_pixel(set, f.noisy, i);
      for (int k = 0; k < 2; ++k) {
        FastPath path;
        const Fit fit = (k == 0 ? fast : plain).fit(p.m, p.w, 4, &path);
        iterations[k] += fit.iterations, chi2[k] += fit.chi2, searched[k] += path == FastPath::kSearched;
      }
    }
    SCOPED_TRACE(noise);
    if (noise > 0) {
      EXPECT_LT(iterations[0], iterations[1] * 7 / 10);
      EXPECT_LE(searched[0], searched[1]);
      EXPECT_LT(chi2[0], chi2[1] * 1.01);
    } else {
      EXPECT_LT(chi2[0] / f.pixels(), 0.012);
      EXPECT_LE(searched[0], searched[1] + 1);
    }
  }
}

// A set whose last channel is far noisier than the others (the lab's
// blue-only difference: ≈ 10× the relative noise): the pre-solved fits must
// weigh with that ratio. With the matching settings, fewer noisy pixels end
// in a bounded minimum above the acceptance χ² (the search path) than with
// equal weights, at a lower mean χ².
TEST(FastInverter, PresolvedFitsWeighWithTheChannelsNoise) {
  const auto table = testing::method_table();
  InverseTableSettings matched;
  matched.relative_sigma = {1, 1, 1, 8};
  const FastInverter equal(table, method_inverse_table()),
      weighted(table, InverseTable::load_or_build(table, ForwardTable::default_cache_dir(), nullptr, nullptr, 0, matched));
  MeasurementSet set = testing::method_set();
  const simulators::SyntheticFrame f = skin_frame(set, 800, 33, 0);
  std::mt19937 random(5);
  std::normal_distribution<double> normal;
  int searched[2] = {};
  double chi2[2] = {};
  for (std::size_t i = 0; i < f.pixels(); ++i) {
    double m[4], w[4];
    for (int c = 0; c < 4; ++c) {
      const double sigma = 0.03 * f.clean[i * 4 + c] * (c == 3 ? 8 : 1);
      m[c] = f.clean[i * 4 + c] + sigma * normal(random);
      w[c] = 1 / sigma;
    }
    for (int k = 0; k < 2; ++k) {
      FastPath path;
      const Fit fit = (k == 0 ? weighted : equal).fit(m, w, 4, &path);
      chi2[k] += fit.chi2, searched[k] += path == FastPath::kSearched;
    }
  }
  EXPECT_LT(searched[0], searched[1] * 85 / 100) << searched[0] << " vs " << searched[1];  // 214 vs 285
  EXPECT_LT(chi2[0], chi2[1]);
}

TEST(InverseTable, NonFiniteOrFarOutsideMeasurementsDoNotCrash) {
  const auto table = testing::method_table();
  const FastInverter fast(table, method_inverse_table());
  const std::vector<double> w(4, 100.0);
  for (const auto& m : std::vector<std::array<double, 4>>{
           {NAN, 0.2, 0.2, 0.2}, {1e9, 1e9, 1e9, 1e9}, {0, 0, 0, 0}, {-1, 0.5, 0.1, 0.3}, {0.9, 0.01, 0.9, 0.01}}) {
    const Fit f = fast.fit(m.data(), w.data(), 4);
    for (double x : f.x) EXPECT_TRUE(std::isfinite(x));
  }
  const float nan_pixel[4] = {NAN, 0.2f, 0.2f, 0.2f};
  EXPECT_EQ(method_inverse_table()->cell_of(nan_pixel), InverseTable::kNoCell);
}

class InverseTableCache : public ::testing::Test {
 protected:
  fs::path dir = fs::temp_directory_path() / ("chromo_inverse_cache_" + std::to_string(::getpid()));
  const TableGrid small{9, 9, 11, 5};
  void SetUp() override { fs::remove_all(dir); }
  void TearDown() override { fs::remove_all(dir); }
  std::shared_ptr<const ForwardTable> small_table(const MeasurementSet& set) {
    return std::make_shared<const ForwardTable>(ForwardTable::build(set, small, 2));
  }
};

TEST_F(InverseTableCache, IsReusedAndRebuiltWhenTheForwardTableChanges) {
  const MeasurementSet set = testing::method_set();
  const auto table = small_table(set);
  bool rebuilt = false;
  std::string warning = "x";
  std::size_t branches = 0, cells = 0;
  {
    const auto first = InverseTable::load_or_build(table, dir, &rebuilt, &warning, 2);
    EXPECT_TRUE(rebuilt);
    EXPECT_TRUE(warning.empty());
    branches = first->branch_count(), cells = first->occupied_cells();
    EXPECT_GT(branches, 0u);
    // Held: the same object, no file read.
    EXPECT_EQ(InverseTable::load_or_build(table, dir, &rebuilt).get(), first.get());
    EXPECT_FALSE(rebuilt);
  }
  // Released: read back from the file, identical.
  const auto second = InverseTable::load_or_build(table, dir, &rebuilt, &warning, 2);
  EXPECT_FALSE(rebuilt);
  EXPECT_TRUE(warning.empty());
  EXPECT_EQ(second->branch_count(), branches);
  EXPECT_EQ(second->occupied_cells(), cells);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), {}), 1);

  // Another illuminant → another forward table → another key and file.
  MeasurementSet other = set;
  other.channels[3].illuminant *= 0.5;
  other.channels[3].illuminant += spectral::led_spectrum(spectral::LedType::kGreen) * 0.1;
  const auto third = InverseTable::load_or_build(small_table(other), dir, &rebuilt, &warning, 2);
  EXPECT_TRUE(rebuilt);
  EXPECT_NE(InverseTable::cache_key(*small_table(other)), InverseTable::cache_key(*table));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), {}), 2);
}

TEST_F(InverseTableCache, ACorruptOrTruncatedFileIsRebuiltWithAWarning) {
  const auto table = small_table(testing::method_set());
  const fs::path file = dir / InverseTable::file_name(InverseTable::cache_key(*table));
  std::size_t branches = 0;
  bool rebuilt = false;
  std::string warning;
  { branches = InverseTable::load_or_build(table, dir, &rebuilt, &warning, 2)->branch_count(); }
  ASSERT_TRUE(fs::exists(file));
  const auto size = fs::file_size(file);
  {
    // One byte flipped in the middle (the branch data): the checksum catches it.
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(static_cast<std::streamoff>(size - 200));
    char byte = 0;
    f.read(&byte, 1);
    byte = static_cast<char>(byte ^ 0x5a);
    f.seekp(static_cast<std::streamoff>(size - 200));
    f.write(&byte, 1);
  }
  {
    const auto again = InverseTable::load_or_build(table, dir, &rebuilt, &warning, 2);
    EXPECT_TRUE(rebuilt);
    EXPECT_NE(warning.find("checksum"), std::string::npos) << warning;
    EXPECT_NE(warning.find(file.string()), std::string::npos) << warning;
    EXPECT_EQ(again->branch_count(), branches);
  }
  // The rebuilt file was written back: it loads without a warning.
  { InverseTable::load_or_build(table, dir, &rebuilt, &warning, 2); }
  EXPECT_FALSE(rebuilt);
  EXPECT_TRUE(warning.empty());
  // Truncated, then garbage: rebuilt with a warning each time, never read.
  fs::resize_file(file, 1000);
  { InverseTable::load_or_build(table, dir, &rebuilt, &warning, 2); }
  EXPECT_TRUE(rebuilt);
  EXPECT_NE(warning.find("truncated"), std::string::npos) << warning;
  std::ofstream(file, std::ios::trunc) << "not a table";
  { InverseTable::load_or_build(table, dir, &rebuilt, &warning, 2); }
  EXPECT_TRUE(rebuilt);
  EXPECT_NE(warning.find("another kind of file"), std::string::npos) << warning;
  EXPECT_GT(fs::file_size(file), 1000u);
}

}  // namespace
}  // namespace chromo::estimation
