#include "chromo/estimation/spatial_flags.hpp"

#include "spatial_internal.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>
#include <limits>

namespace chromo::estimation {

bool NeighbourhoodOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (!(background_sigma_px >= 1 && background_sigma_px <= 100)) return fail("background_sigma_px must be 1-100");
  if (!(deviation_sigma_px >= 0.3 && deviation_sigma_px <= 20)) return fail("deviation_sigma_px must be 0.3-20");
  if (!(background_sigma_relative >= 0)) return fail("background_sigma_relative must be >= 0");
  if (!(significance > 0 && significance < 1) || !(rim_significance > 0 && rim_significance < 1))
    return fail("significance and rim_significance must be in (0, 1)");
  if (!(reflection_significance > 0 && reflection_significance < 0.5))
    return fail("reflection_significance must be in (0, 0.5)");
  if (!(mixture_significance > 0 && mixture_significance < 0.5))
    return fail("mixture_significance must be in (0, 0.5)");
  if (exclusion_px < 0 || exclusion_px > 100) return fail("exclusion_px must be 0-100");
  if (!(misfit_sigma_px >= 1 && misfit_sigma_px <= 200)) return fail("misfit_sigma_px must be 1-200");
  if (!(misfit_ratio >= 1)) return fail("misfit_ratio must be >= 1");
  if (max_hole_px < 0) return fail("max_hole_px must be >= 0");
  if (max_passes < 1 || max_growth_passes < 0) return fail("max_passes must be >= 1 and max_growth_passes >= 0");
  if (order_window_px < 1 || order_window_px > 63) return fail("order_window_px must be 1-63");
  if (block_px < 0 || block_px > 64) return fail("block_px must be 0 (from the image size) or 1-64");
  if (reference_width_px < 16) return fail("reference_width_px must be >= 16");
  return local_bias.IsValid(error);
}

void detail::check_neighbourhood_sizes(const Estimator& estimator, std::span<const float> measured, int width,
                                       int height, std::span<PixelEstimate> estimates,
                                       const NeighbourhoodOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("neighbourhood options: " + error);
  if (width < 1 || height < 1 || estimates.size() != static_cast<std::size_t>(width) * height ||
      measured.size() != estimates.size() * static_cast<std::size_t>(estimator.channels()))
    throw std::invalid_argument("spatial pass: " + std::to_string(width) + "x" + std::to_string(height) + " pixels, " +
                                std::to_string(estimates.size()) + " estimates, " + std::to_string(measured.size()) +
                                " measured values");
}

namespace {

using detail::background;
using detail::filter;
using detail::kernel;

// One resolution of the flag pass: the estimator's cells (block 1), or blocks
// of block × block cells, each holding the mean of its explained cells (noise
// σ/√cells) and flagged when most of its cells are.
enum LevelState : std::uint8_t { kOpen = 0, kFlaggedBefore = 1, kJoined = 2, kHole = 3 };
// A block seeds (a deviating region touching it joins) when at least this
// share of its cells (and at least one) was flagged by the first pass: a
// lone cell flagged by noise (0.01% of the skin) must not make a whole mole
// join, as one block's mean it is not what the block shows. (All cells seed
// at block 1.)
constexpr float kSeedShare = 0.2f;
struct Level {
  int width = 0, height = 0;
  std::vector<cv::Mat> values;  // per channel, CV_32F: the explained cells' mean (0 where none)
  cv::Mat cells;                // CV_32F: explained cells averaged into the pixel
  cv::Mat state;                // CV_8U LevelState
  cv::Mat seed;                 // CV_8U: holds a cell flagged before the pass (a region touching it joins)
  cv::Mat reflection;           // CV_8U: holds a specular or saturated cell, or joined one (a white region touching it joins)
  std::vector<cv::Mat> all_values;  // per channel, CV_32F: the mean of all its cells, flagged ones too (NaN if one is not finite)
  std::vector<cv::Mat> background;  // per channel, the background a joined pixel was judged against (else NaN)
};

Level make_level(int channels, std::span<const float> measured, int width, int height,
                 std::span<const PixelEstimate> estimates, int block) {
  Level level;
  level.width = (width + block - 1) / block, level.height = (height + block - 1) / block;
  const cv::Size size(level.width, level.height);
  level.values.assign(channels, cv::Mat());
  for (cv::Mat& v : level.values) v = cv::Mat(size, CV_32F, cv::Scalar(0));
  level.cells = cv::Mat(size, CV_32F, cv::Scalar(0));
  level.seed = cv::Mat(size, CV_8U, cv::Scalar(0));
  level.reflection = cv::Mat(size, CV_8U, cv::Scalar(0));
  level.all_values.assign(channels, cv::Mat());
  for (cv::Mat& v : level.all_values) v = cv::Mat(size, CV_32F, cv::Scalar(0));
  cv::Mat all(size, CV_32F, cv::Scalar(0)), flagged(size, CV_32F, cv::Scalar(0)), reflection(size, CV_32F, cv::Scalar(0));
  for (std::size_t p = 0; p < estimates.size(); ++p) {
    const int y = static_cast<int>(p / width) / block, x = static_cast<int>(p % width) / block;
    all.at<float>(y, x) += 1;
    for (int c = 0; c < channels; ++c) {
      const float m = measured[p * channels + c];
      level.all_values[c].at<float>(y, x) += std::isfinite(m) ? m : std::numeric_limits<float>::quiet_NaN();
    }
    if (estimates[p].flag != PixelFlag::kExplained) {
      flagged.at<float>(y, x) += 1;
      if (estimates[p].flag == PixelFlag::kSpecular || estimates[p].flag == PixelFlag::kSaturated)
        reflection.at<float>(y, x) += 1;
      continue;
    }
    level.cells.at<float>(y, x) += 1;
    for (int c = 0; c < channels; ++c) level.values[c].at<float>(y, x) += measured[p * channels + c];
  }
  level.state = cv::Mat(size, CV_8U, cv::Scalar(kOpen));
  for (int y = 0; y < level.height; ++y)
    for (int x = 0; x < level.width; ++x) {
      const float cells = level.cells.at<float>(y, x);
      if (cells > 0)
        for (cv::Mat& v : level.values) v.at<float>(y, x) /= cells;
      for (cv::Mat& v : level.all_values) v.at<float>(y, x) /= all.at<float>(y, x);
      if (2 * cells <= all.at<float>(y, x)) level.state.at<std::uint8_t>(y, x) = kFlaggedBefore;
      const float seed_cells = std::max(1.0f, kSeedShare * all.at<float>(y, x));
      level.seed.at<std::uint8_t>(y, x) = flagged.at<float>(y, x) >= seed_cells;
      level.reflection.at<std::uint8_t>(y, x) =
          reflection.at<float>(y, x) >= seed_cells && 2 * reflection.at<float>(y, x) >= flagged.at<float>(y, x);
    }
  return level;
}

// The three test levels of the header, for `channels` channels: the χ²
// deviation test, its hysteresis (rim) level, and the one-sided white
// reflection test (P(w > t) = α ⇔ P(w² > t²) = 2α under N(0, 1)).
struct TestLevels {
  double deviation, rim, white, mixture;
};

TestLevels test_levels(const NeighbourhoodOptions& options, int channels) {
  return {chi_squared_quantile(1 - options.significance, channels),
          chi_squared_quantile(1 - options.rim_significance, channels),
          std::sqrt(chi_squared_quantile(1 - 2 * options.reflection_significance, 1)),
          std::sqrt(chi_squared_quantile(1 - 2 * options.mixture_significance, 1))};
}

// The deviation statistic of steps 1-2 against one background: per pixel
// u (the averaged deviation, unit variance under camera noise alone), σ_c,
// whether it is tested, and per kMisfitBlock-px block M⁻¹ (noise plus the
// skin's misfit; none where noise alone).
constexpr int kMisfitBlock = 4;
// Any channel count: the per-pixel loops below reuse preallocated vectors
// (no allocation per pixel).
using Matrix = Eigen::MatrixXd;
using Vector = Eigen::VectorXd;
struct Deviation {
  std::vector<cv::Mat> u, sigmas;
  cv::Mat tested;
  int block_cols = 0;
  std::vector<Matrix> inverse;
  std::vector<char> misfit;
  void u_at(int y, int x, Vector& v) const {
    for (std::size_t c = 0; c < u.size(); ++c) v[static_cast<Eigen::Index>(c)] = u[c].at<float>(y, x);
  }
  // M⁻¹ at (y, x), or null where noise alone (M = I).
  const Matrix* misfit_inverse(int y, int x) const {
    const std::size_t block = static_cast<std::size_t>(y / kMisfitBlock) * block_cols + x / kMisfitBlock;
    return misfit[block] ? &inverse[block] : nullptr;
  }
};

// The one-sided matched filter of u = v along the direction a (in u's
// units): w = aᵀM⁻¹v / √(aᵀM⁻¹a), N(0, 1) under noise plus misfit; −∞ for a
// = 0. scratch: a vector of a's size (overwritten).
double matched_statistic(const Vector& a, const Vector& v, const Matrix* misfit_inverse, Vector& scratch) {
  if (misfit_inverse) scratch.noalias() = *misfit_inverse * a;
  const Vector& ma = misfit_inverse ? scratch : a;
  const double norm2 = ma.dot(a);
  return norm2 > 0 ? ma.dot(v) / std::sqrt(norm2) : -std::numeric_limits<double>::infinity();
}

Deviation deviation(const Estimator& estimator, const Level& level, const cv::Mat& good, const cv::Mat& steady,
                    const cv::Mat& deviating, const cv::Mat& source, const std::vector<cv::Mat>& back,
                    const NeighbourhoodOptions& options) {
  const int channels = estimator.channels(), width = level.width, height = level.height;
  const std::vector<cv::Mat>& values = level.values;
  const cv::Mat h = kernel(options.deviation_sigma_px, 0);
  cv::Mat h2;
  cv::multiply(h, h, h2);
  // Noise-normalised deviation, averaged over the neighbours of the same class.
  std::vector<cv::Mat> z(channels), sigmas(channels);
  for (int c = 0; c < channels; ++c) {
    z[c] = cv::Mat(height, width, CV_32F, cv::Scalar(0));
    sigmas[c] = cv::Mat(height, width, CV_32F, cv::Scalar(1));
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const float b = back[c].at<float>(y, x);
        if (!good.at<float>(y, x) || !std::isfinite(b)) continue;
        const double m = values[c].at<float>(y, x);
        const double w = estimator.weight(c, m);
        const double model = options.background_sigma_relative * m;
        const double sigma = std::sqrt(1 / (w * w * level.cells.at<float>(y, x)) + model * model);
        z[c].at<float>(y, x) = static_cast<float>((m - b) / sigma);
        sigmas[c].at<float>(y, x) = static_cast<float>(sigma);
      }
  }
  // Per class, the averaged deviation scaled to unit variance under camera
  // noise alone: u_c = z̄_c·√n_eff, n_eff = (Σg)²/Σg².
  std::vector<cv::Mat> u(channels);
  for (cv::Mat& m : u) m = cv::Mat(height, width, CV_32F, cv::Scalar(0));
  cv::Mat tested(height, width, CV_8U, cv::Scalar(0));
  for (const cv::Mat* cls : {&steady, &deviating}) {
    const cv::Mat sum_g = filter(*cls, h, h), sum_g2 = filter(*cls, h2, h2);
    std::vector<cv::Mat> z_mean(channels);
    for (int c = 0; c < channels; ++c) z_mean[c] = filter(z[c].mul(*cls), h, h);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        if (!cls->at<float>(y, x) || !std::isfinite(back[0].at<float>(y, x))) continue;
        const double sg = sum_g.at<float>(y, x), sg2 = sum_g2.at<float>(y, x);
        if (!(sg > 0 && sg2 > 0)) continue;
        tested.at<std::uint8_t>(y, x) = 1;
        for (int c = 0; c < channels; ++c) u[c].at<float>(y, x) = static_cast<float>(z_mean[c].at<float>(y, x) / std::sqrt(sg2));
      }
  }
  // The skin's own scatter around its background: the local second moments
  // E[u uᵀ] of the background's source pixels (steady skin away from flagged
  // ones) over misfit_sigma_px. Camera noise alone gives the identity; where
  // the quadratic background cannot follow the skin (fields finer than its
  // window, or less noise at a longer exposure) the misfit adds to it, and
  // the statistic is measured against noise plus misfit: T = uᵀ M⁻¹ u with M
  // = E floored at the identity (eigenvalues ≥ 1).
  // The moments vary over misfit_sigma_px, so they (and M⁻¹) are computed
  // on a grid of kMisfitBlock-px blocks (area averages, filtered with the
  // kernel scaled down) and each pixel uses its block's.
  // Its source is the background's. (Tried: also excluding 6 or 12 px
  // around deviating pixels, so that an undetected rim beside them does not
  // count as misfit and hide itself: specular +28-40 points at 256 px, but
  // 6-15% of the skin flagged at 128 px, where hair strands leave little
  // skin that far from anything.)
  const int block_cols = (width + kMisfitBlock - 1) / kMisfitBlock, block_rows = (height + kMisfitBlock - 1) / kMisfitBlock;
  auto to_blocks = [&](const cv::Mat& m) {
    cv::Mat padded, out;
    cv::copyMakeBorder(m, padded, 0, block_rows * kMisfitBlock - height, 0, block_cols * kMisfitBlock - width,
                       cv::BORDER_CONSTANT, 0);
    cv::resize(padded, out, cv::Size(block_cols, block_rows), 0, 0, cv::INTER_AREA);
    return out;
  };
  const cv::Mat kw = kernel(options.misfit_sigma_px / kMisfitBlock, 0);
  cv::Mat source_u;
  source.copyTo(source_u);
  source_u.setTo(0, tested == 0);
  const cv::Mat moment_mass = filter(to_blocks(source_u), kw, kw);
  std::vector<cv::Mat> moment;
  for (int c = 0; c < channels; ++c)
    for (int d = c; d < channels; ++d) moment.push_back(filter(to_blocks(u[c].mul(u[d]).mul(source_u)), kw, kw));
  const double min_mass = 0.05 * std::pow(cv::sum(kw)[0], 2);
  // Per block: M⁻¹, or none (noise alone: M = I).
  std::vector<Matrix> inverse(static_cast<std::size_t>(block_cols) * block_rows);
  std::vector<char> misfit(inverse.size(), 0);
  Matrix e(channels, channels);
  Eigen::SelfAdjointEigenSolver<Matrix> eigen(channels);
  for (int by = 0; by < block_rows; ++by)
    for (int bx = 0; bx < block_cols; ++bx) {
      const double mass = moment_mass.at<float>(by, bx);
      if (!(mass > min_mass)) continue;
      double largest = 0;
      for (int c = 0, k = 0; c < channels; ++c)
        for (int d = c; d < channels; ++d, ++k) {
          e(c, d) = e(d, c) = moment[k].at<float>(by, bx) / mass;
          if (c == d) largest = std::max(largest, e(c, c));
        }
      if (largest <= options.misfit_ratio) continue;  // noise alone
      eigen.compute(e);
      const Vector lambda = eigen.eigenvalues().cwiseMax(1.0);
      const std::size_t i = static_cast<std::size_t>(by) * block_cols + bx;
      inverse[i] = eigen.eigenvectors() * lambda.cwiseInverse().asDiagonal() * eigen.eigenvectors().transpose();
      misfit[i] = 1;
    }
  return {std::move(u), std::move(sigmas), std::move(tested), block_cols, std::move(inverse), std::move(misfit)};
}

// Steps 1-5 of the header on one level; joined and enclosed pixels get
// kJoined and kHole. All windows in the level's pixels.
void flag_level(const Estimator& estimator, Level& level, const NeighbourhoodOptions& options,
                NeighbourhoodSummary& summary) {
  const int channels = estimator.channels(), width = level.width, height = level.height;
  const TestLevels levels = test_levels(options, channels);
  const double deviation_threshold = levels.deviation, rim_threshold = levels.rim, white_threshold = levels.white;
  const std::vector<cv::Mat>& values = level.values;

  // Deviating pixels, kept across passes: they leave the background (so a
  // vessel or a rim does not bias the skin next to it) and are averaged only
  // with each other (so they do not bleed into that skin either).
  cv::Mat candidate(height, width, CV_8U, cv::Scalar(0));
  level.background.assign(channels, cv::Mat());
  for (cv::Mat& b : level.background) b = cv::Mat(height, width, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  // Partial covers (step 4b): per pixel, the mean value of the flagged
  // material among its 8 neighbours (flagged before the pass, not a
  // reflection: ink, dye, hair; none where the count is 0). A cover c of it
  // over the pixel's skin moves the pixel by c·(material − background).
  std::vector<cv::Mat> material_mean(channels);
  cv::Mat material_count;
  if (options.grow_mixtures) {
    cv::Mat valid = (level.state == kFlaggedBefore) & (level.reflection == 0);
    for (const cv::Mat& v : level.all_values) valid &= (v == v);  // NaN: a cell without a value
    cv::Mat valid_f;
    valid.convertTo(valid_f, CV_32F, 1.0 / 255);
    cv::boxFilter(valid_f, material_count, CV_32F, cv::Size(3, 3), cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
    for (int c = 0; c < channels; ++c) {
      cv::Mat v = level.all_values[c].clone(), sum;
      v.setTo(0, valid == 0);
      cv::boxFilter(v, sum, CV_32F, cv::Size(3, 3), cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
      cv::divide(sum, cv::max(material_count, 1.0f), material_mean[c]);
    }
  }
  int settling = 0;
  const bool grow = options.grow_reflections || options.grow_mixtures;
  const int max_passes = options.max_passes + (grow ? options.max_growth_passes : 0);
  for (int pass = 0; pass < max_passes; ++pass) {
    summary.passes = pass + 1;
    cv::Mat good;
    cv::Mat(level.state == kOpen).convertTo(good, CV_32F, 1.0 / 255);
    cv::Mat deviating, steady;
    candidate.convertTo(deviating, CV_32F);
    deviating = deviating.mul(good);
    steady = good - deviating;
    // The background comes from skin at least exclusion_px away from flagged pixels: a flagged
    // region's weak rim must not be its own background.
    cv::Mat flagged_band, source;
    cv::dilate(good == 0, flagged_band, cv::getStructuringElement(cv::MORPH_ELLIPSE,
               cv::Size(2 * options.exclusion_px + 1, 2 * options.exclusion_px + 1)));
    steady.copyTo(source);
    source.setTo(0, flagged_band);
    const std::vector<cv::Mat> back = background(values, source, options.background_sigma_px);
    auto join = [&](int y, int x) {
      level.state.at<std::uint8_t>(y, x) = kJoined, candidate.at<std::uint8_t>(y, x) = 0;
      for (int c = 0; c < channels; ++c) level.background[c].at<float>(y, x) = back[c].at<float>(y, x);
    };

    const Deviation dev = deviation(estimator, level, good, steady, deviating, source, back, options);
    cv::Mat next(height, width, CV_8U, cv::Scalar(0)), rim;
    cv::dilate(good == 0, rim, cv::Mat::ones(3, 3, CV_8U));
    cv::Mat white(height, width, CV_8U, cv::Scalar(0)), mixed(height, width, CV_8U, cv::Scalar(0));
    Vector v(channels), a(channels), mv(channels), scratch(channels);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        if (!dev.tested.at<std::uint8_t>(y, x)) continue;
        dev.u_at(y, x, v);
        const Matrix* misfit_inverse = dev.misfit_inverse(y, x);
        if (misfit_inverse) mv.noalias() = *misfit_inverse * v;
        const double t = misfit_inverse ? v.dot(mv) : v.squaredNorm();
        if (t > (rim.at<std::uint8_t>(y, x) ? rim_threshold : deviation_threshold)) next.at<std::uint8_t>(y, x) = 1;
        // A white surface reflection s adds s/σ_c to z_c: the matched
        // one-sided test along a_c = 1/σ_c against the same noise plus misfit.
        // A partial cover c of the material beside it adds c·d_c/σ_c: the
        // same test along that direction.
        if (options.grow_reflections) {
          for (int c = 0; c < channels; ++c) a[c] = 1 / dev.sigmas[c].at<float>(y, x);
          if (matched_statistic(a, v, misfit_inverse, scratch) > white_threshold) white.at<std::uint8_t>(y, x) = 1;
        }
        if (options.grow_mixtures && material_count.at<float>(y, x) > 0) {
          for (int c = 0; c < channels; ++c)
            a[c] = (material_mean[c].at<float>(y, x) - back[c].at<float>(y, x)) / dev.sigmas[c].at<float>(y, x);
          if (matched_statistic(a, v, misfit_inverse, scratch) > levels.mixture) mixed.at<std::uint8_t>(y, x) = 1;
        }
      }
    const bool changed = cv::countNonZero(next != candidate) > 0;
    candidate = next;
    if (changed && ++settling < 6) continue;  // let the deviating set settle before deciding
    settling = 0;

    // Regions of deviating pixels that touch a flagged pixel join it.
    cv::Mat labels, stats, centroids;
    const int regions = cv::connectedComponentsWithStats(candidate, labels, stats, centroids, 8, CV_32S);
    if (regions <= 1 && !grow) break;
    cv::Mat flagged_near;
    cv::dilate(level.seed | (level.state != kOpen), flagged_near, cv::Mat::ones(3, 3, CV_8U));
    std::vector<char> touches(regions, 0);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const int r = labels.at<int>(y, x);
        if (r == 0) continue;
        if (flagged_near.at<std::uint8_t>(y, x) && pass < options.max_passes) touches[r] = 1;
      }
    std::size_t added = 0;
    for (int r = 1; r < regions; ++r)
      if (touches[r]) added += static_cast<std::size_t>(stats.at<int>(r, cv::CC_STAT_AREA));
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const int r = labels.at<int>(y, x);
        if (r > 0 && touches[r]) join(y, x);
      }
    // Reflections grow, in rounds where no deviating region joined: open
    // regions of white pixels touching a specular, saturated or so-joined
    // pixel join it (a highlight's rim brighter than the skin around it in
    // every channel alike). (Growing in the same rounds as the joins made the
    // end path-dependent: at 5 MP specular 63 / 86 / 89 / 71% at 10⁻³ / 5·10⁻³
    // / 10⁻² / 1.5·10⁻²; after them 70 / 76 / 82%.)
    const bool growth_round = added == 0 || pass >= options.max_passes;
    if (options.grow_reflections && growth_round) {
      const cv::Mat open_white = white & (level.state == kOpen);
      const int white_regions = cv::connectedComponents(open_white, labels, 8, CV_32S);
      cv::dilate(level.reflection, flagged_near, cv::Mat::ones(3, 3, CV_8U));
      std::vector<char> grows(white_regions, 0);
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
          if (const int r = labels.at<int>(y, x); r > 0 && flagged_near.at<std::uint8_t>(y, x)) grows[r] = 1;
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
          if (const int r = labels.at<int>(y, x); r > 0 && grows[r]) {
            join(y, x);
            level.reflection.at<std::uint8_t>(y, x) = 1;
            ++added;
          }
    }
    // Partial covers join in the same rounds, one ring beside the material.
    if (options.grow_mixtures && growth_round)
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
          if (mixed.at<std::uint8_t>(y, x) && level.state.at<std::uint8_t>(y, x) == kOpen) {
            join(y, x);
            ++added;
          }
    if (added == 0) break;
  }
  // Holes: explained pixels enclosed by flagged ones (not reaching the image
  // border) in a region of at most max_hole_px belong to what surrounds them
  // (the middle of a highlight whose core and rim are flagged, the gap in a
  // stroke). Skin is not found inside a highlight or an ink disk.
  if (options.max_hole_px > 0) {
    const cv::Mat open = level.state == kOpen;
    cv::Mat labels, stats, centroids;
    const int regions = cv::connectedComponentsWithStats(open, labels, stats, centroids, 4, CV_32S);
    std::vector<char> hole(regions, 0);
    for (int r = 1; r < regions; ++r) {
      const int x = stats.at<int>(r, cv::CC_STAT_LEFT), y = stats.at<int>(r, cv::CC_STAT_TOP);
      const int w = stats.at<int>(r, cv::CC_STAT_WIDTH), h = stats.at<int>(r, cv::CC_STAT_HEIGHT);
      hole[r] = x > 0 && y > 0 && x + w < width && y + h < height && stats.at<int>(r, cv::CC_STAT_AREA) <= options.max_hole_px;
    }
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const int r = labels.at<int>(y, x);
        if (r > 0 && hole[r]) level.state.at<std::uint8_t>(y, x) = kHole;
      }
  }
}

}  // namespace

int neighbourhood_block_px(int width, int height, const NeighbourhoodOptions& options) {
  if (options.block_px > 0) return options.block_px;
  const int longer = std::max(width, height);
  if (longer <= 2 * options.reference_width_px) return 1;
  return static_cast<int>(std::lround(static_cast<double>(longer) / options.reference_width_px));
}

NeighbourhoodSummary refine_flags_with_neighbourhood(const Estimator& estimator, std::span<const float> measured,
                                                     int width, int height, std::span<PixelEstimate> estimates,
                                                     const NeighbourhoodOptions& options) {
  detail::check_neighbourhood_sizes(estimator, measured, width, height, estimates, options);
  NeighbourhoodSummary summary;
  summary.block_px = neighbourhood_block_px(width, height, options);
  const int block = summary.block_px;
  const int channels = estimator.channels();
  Level level = make_level(channels, measured, width, height, estimates, block);
  flag_level(estimator, level, options, summary);
  // Back to the cells. A block joined or enclosed whose neighbours are all
  // flagged passes its flag to its explained cells; one on the edge of a
  // flagged region (an open 8-neighbour) holds both sides of that edge, and
  // passes it only to its cells that deviate on their own from the
  // background (interpolated between blocks) at the rim significance: the
  // χ² test or the one-sided white test above, with one cell's noise.
  cv::Mat edge;
  cv::dilate(level.state == kOpen, edge, cv::Mat::ones(3, 3, CV_8U));
  std::vector<cv::Mat> back(channels);
  if (block > 1)
    for (int c = 0; c < channels; ++c)
      cv::resize(level.background[c], back[c], cv::Size(level.width * block, level.height * block), 0, 0, cv::INTER_LINEAR);
  const TestLevels levels = test_levels(options, channels);
  const double rim_threshold = levels.rim, white_threshold = levels.white;
  auto deviates = [&](std::size_t p, int y, int x, bool reflection) {
    double chi2 = 0, white = 0, white_norm = 0;
    for (int c = 0; c < channels; ++c) {
      double b = back[c].at<float>(y, x);  // between blocks, or the cell's block's own where a neighbour has none
      if (!std::isfinite(b)) b = level.background[c].at<float>(y / block, x / block);
      const double m = measured[p * channels + c];
      if (!std::isfinite(b)) return true;
      const double w = estimator.weight(c, m);  // 1/σ_c
      chi2 += (m - b) * (m - b) * w * w;
      white += (m - b) * w * w, white_norm += w * w;
    }
    return chi2 > rim_threshold || (reflection && white > white_threshold * std::sqrt(white_norm));
  };
  for (std::size_t p = 0; p < estimates.size(); ++p) {
    if (estimates[p].flag != PixelFlag::kExplained) continue;
    const int y = static_cast<int>(p / width), x = static_cast<int>(p % width);
    const std::uint8_t s = level.state.at<std::uint8_t>(y / block, x / block);
    if (s != kJoined && s != kHole) continue;
    const bool reflection = level.reflection.at<std::uint8_t>(y / block, x / block);
    const bool alone = s == kJoined && !reflection;
    if (block > 1 && (alone || edge.at<std::uint8_t>(y / block, x / block)) && !deviates(p, y, x, reflection)) continue;
    estimates[p].flag = PixelFlag::kNeighbourhood;
    ++(s == kJoined ? summary.flagged_touching : summary.flagged_holes);
  }
  return summary;
}

NeighbourhoodSummary refine_with_neighbourhood(const Estimator& estimator, std::span<const float> measured, int width,
                                               int height, std::span<PixelEstimate> estimates, EstimateSummary& summary,
                                               const NeighbourhoodOptions& options,
                                               std::span<const OtherOrderFit> other) {
  NeighbourhoodSummary s;
  if (options.flags) s = refine_flags_with_neighbourhood(estimator, measured, width, height, estimates, options);
  if (options.pool_order) {
    const NeighbourhoodSummary order = pool_model_order(estimator, measured, width, height, estimates, options, other);
    s.order_to_2 = order.order_to_2, s.order_to_4 = order.order_to_4;
  }
  std::fill(std::begin(summary.flag_counts), std::end(summary.flag_counts), 0);
  summary.order2 = summary.order4 = 0;
  for (const PixelEstimate& e : estimates) {
    ++summary.flag_counts[static_cast<int>(e.flag)];
    summary.order2 += e.order == 2;
    summary.order4 += e.order == 4;
  }
  return s;
}

}  // namespace chromo::estimation
