#include "tile_motion.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "chromo/session/registration.hpp"
#include "translation_fit.hpp"

namespace chromo::session::registration_detail {

namespace {

// One tile's measured translation, full-resolution px, at its centre.
struct TileVote {
  Eigen::Vector2d centre, shift;
  bool textured = false;  // gradient_snr ≥ kMinimumTileGradientSnr
};

// The moving capture resampled onto the reference's grid by `warp`, both
// brought to a level of at most ~1.2 MP; `scale`: full-resolution px per working px.
struct WorkingPair {
  cv::Mat ref, aligned, valid;
  double scale = 1;
};

WorkingPair working_pair(const cv::Mat& ref, const cv::Mat& ref_valid, const cv::Mat& mov, const cv::Mat& mov_valid,
                         const cv::Mat& warp) {
  WorkingPair w{ref, {}, {}, 1};
  cv::warpAffine(mov, w.aligned, warp, mov.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
  cv::warpAffine(mov_valid, w.valid, warp, mov.size(), cv::INTER_NEAREST | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT, 0);
  w.valid &= ref_valid;
  while (static_cast<double>(w.ref.rows) * w.ref.cols > 1.2e6) {
    cv::Mat r, m, k;
    cv::pyrDown(w.ref, r), cv::pyrDown(w.aligned, m);
    cv::resize(w.valid, k, m.size(), 0, 0, cv::INTER_NEAREST);
    cv::erode(k, k, cv::Mat());
    w.ref = r, w.aligned = m, w.valid = k, w.scale *= 2;
  }
  return w;
}

std::vector<TileVote> tile_votes(const WorkingPair& w) {
  std::vector<TileVote> votes;
  const int side = std::clamp(std::min(w.ref.cols, w.ref.rows) / 4, kSmallestTileSidePx, kTileSidePx);
  const int nx = std::max(1, w.ref.cols / side), ny = std::max(1, w.ref.rows / side);
  for (int by = 0; by < ny; ++by)
    for (int bx = 0; bx < nx; ++bx) {
      const cv::Rect tile(bx * w.ref.cols / nx, by * w.ref.rows / ny, w.ref.cols / nx, w.ref.rows / ny);
      if (tile.width < 8 || tile.height < 8) continue;
      const TranslationFit fit = translation_least_squares(w.ref(tile), w.aligned(tile), w.valid(tile), 5);
      const bool measured = fit.solved && 3 * std::max(fit.sigma_x, fit.sigma_y) <= kTranslationFallbackUncertaintyPx;
      if (!measured || !std::isfinite(fit.tx) || !std::isfinite(fit.ty)) continue;
      const Eigen::Vector2d centre(tile.x + 0.5 * (tile.width - 1), tile.y + 0.5 * (tile.height - 1));
      votes.push_back({w.scale * centre, w.scale * Eigen::Vector2d(fit.tx, fit.ty), fit.gradient_snr >= kMinimumTileGradientSnr});
    }
  return votes;
}

// Rows of the linear model t = T + θ·(−dy, dx) for one tile: 2 × 3.
Eigen::Matrix<double, 2, 3> model_rows(const Eigen::Vector2d& offset) {
  Eigen::Matrix<double, 2, 3> a;
  a << 1, 0, -offset.y(), 0, 1, offset.x();
  return a;
}

struct Fit {
  Eigen::Vector3d params = Eigen::Vector3d::Zero();  // T_x, T_y (px), θ (rad)
  Eigen::Matrix3d normal_inverse = Eigen::Matrix3d::Zero();
  double residual_variance = 0;  // per axis, px²
};

Fit fit_kept(const std::vector<TileVote>& votes, const std::vector<bool>& kept, const Eigen::Vector2d& centre) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d right = Eigen::Vector3d::Zero();
  int n = 0;
  for (std::size_t i = 0; i < votes.size(); ++i)
    if (kept[i]) {
      const auto a = model_rows(votes[i].centre - centre);
      normal += a.transpose() * a, right += a.transpose() * votes[i].shift, ++n;
    }
  Fit f;
  f.normal_inverse = normal.inverse();
  f.params = normal.ldlt().solve(right);
  double squares = 0;
  for (std::size_t i = 0; i < votes.size(); ++i)
    if (kept[i]) squares += (model_rows(votes[i].centre - centre) * f.params - votes[i].shift).squaredNorm();
  f.residual_variance = squares / std::max(1, 2 * n - 3);
  return f;
}

// Outliers left out until the kept set settles (at most 5 rounds).
std::vector<bool> kept_tiles(const std::vector<TileVote>& votes, const Eigen::Vector2d& centre) {
  std::vector<bool> kept(votes.size(), true);
  for (int round = 0; round < 5; ++round) {
    const Fit f = fit_kept(votes, kept, centre);
    std::vector<double> lengths(votes.size()), kept_lengths;
    for (std::size_t i = 0; i < votes.size(); ++i) {
      lengths[i] = (model_rows(votes[i].centre - centre) * f.params - votes[i].shift).norm();
      if (kept[i]) kept_lengths.push_back(lengths[i]);
    }
    std::nth_element(kept_lengths.begin(), kept_lengths.begin() + kept_lengths.size() / 2, kept_lengths.end());
    // The median length of a 2-D normal residual is 1.1774 σ per axis; a floor keeps noise-free tiles.
    const double spread = std::max(kept_lengths[kept_lengths.size() / 2] / 1.1774, 1e-3);
    std::vector<bool> next(votes.size());
    for (std::size_t i = 0; i < votes.size(); ++i) next[i] = lengths[i] <= kTileOutlierSpreads * spread;
    if (2 * std::count(next.begin(), next.end(), true) < static_cast<long>(votes.size()))
      return std::vector<bool>(votes.size(), true);
    if (next == kept) break;
    kept = next;
  }
  return kept;
}

}  // namespace

TileMotion tile_motion(const cv::Mat& ref, const cv::Mat& ref_valid, const cv::Mat& mov, const cv::Mat& mov_valid,
                       const cv::Mat& base_warp) {
  TileMotion result;
  const std::vector<TileVote> votes = tile_votes(working_pair(ref, ref_valid, mov, mov_valid, base_warp));
  result.tiles_measured = static_cast<int>(votes.size());
  if (result.tiles_measured < kMinimumTiles) return result;
  // Too smooth a view: most tiles' translations pulled toward the start.
  const auto textured = std::count_if(votes.begin(), votes.end(), [](const TileVote& v) { return v.textured; });
  if (2 * textured < static_cast<long>(votes.size())) return result;
  const Eigen::Vector2d centre(0.5 * (ref.cols - 1), 0.5 * (ref.rows - 1));
  const std::vector<bool> kept = kept_tiles(votes, centre);
  const Fit f = fit_kept(votes, kept, centre);
  result.tiles_kept = static_cast<int>(std::count(kept.begin(), kept.end(), true));
  const Eigen::Matrix3d covariance = f.residual_variance * f.normal_inverse;
  double worst = 0;
  for (double x : {0.0, ref.cols - 1.0})
    for (double y : {0.0, ref.rows - 1.0}) {
      const auto a = model_rows(Eigen::Vector2d(x, y) - centre);
      worst = std::max(worst, (a * covariance * a.transpose()).trace());
    }
  result.noise_px = std::sqrt(worst);
  // The tiles' correction C(x) = R(θ)(x − c) + c + T, then the base: base ∘ C.
  const double theta = f.params[2], cs = std::cos(theta), sn = std::sin(theta);
  Eigen::Matrix3d correction = Eigen::Matrix3d::Identity(), base = Eigen::Matrix3d::Identity();
  correction.topLeftCorner<2, 2>() << cs, -sn, sn, cs;
  correction.topRightCorner<2, 1>() = centre + f.params.head<2>() - correction.topLeftCorner<2, 2>() * centre;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) base(i, j) = base_warp.at<float>(i, j);
  const Eigen::Matrix3d total = base * correction;
  result.warp = cv::Mat(2, 3, CV_32F);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) result.warp.at<float>(i, j) = static_cast<float>(total(i, j));
  result.measured = true;
  return result;
}

}  // namespace chromo::session::registration_detail
