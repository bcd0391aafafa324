#include "chromo/estimation/subspace_table.hpp"

#include <omp.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>

#include "chromo/files/fnv1a.hpp"

#include "cell_position.hpp"

namespace chromo::estimation {

namespace {
using Float8 = float __attribute__((vector_size(32)));
static_assert(SubspaceTable::kDims == 8, "predict() holds one node in one Float8");
}  // namespace

SubspaceTable::SubspaceTable(std::shared_ptr<const ForwardTable> table, std::span<const double> reference_sigma,
                             int threads)
    : table_(std::move(table)) {
  if (!table_ || table_->channels() == 0 || table_->values().empty())
    throw std::invalid_argument("subspace table: the forward table is empty");
  channels_ = table_->channels();
  if (static_cast<int>(reference_sigma.size()) != channels_)
    throw std::invalid_argument("subspace table: " + std::to_string(reference_sigma.size()) + " reference sigmas for " +
                                std::to_string(channels_) + " channels");
  for (int c = 0; c < channels_; ++c)
    if (!(std::isfinite(reference_sigma[c]) && reference_sigma[c] > 0))
      throw std::invalid_argument("subspace table: reference sigma of channel " + std::to_string(c) +
                                  " must be finite and > 0");
  sigma_.assign(reference_sigma.begin(), reference_sigma.end());
  const int c_count = channels_;
  scale_.resize(c_count);
  for (int c = 0; c < c_count; ++c) scale_[c] = static_cast<float>(1 / sigma_[c]);
  const std::size_t n = table_->grid().node_count();
  const float* v = table_->values().data();
  const int thread_count = threads > 0 ? threads : omp_get_num_procs();

  // Mean and covariance of the whitened node values, in blocks (one GEMM each).
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(c_count);
  Eigen::MatrixXd second = Eigen::MatrixXd::Zero(c_count, c_count);
  constexpr std::size_t kBlock = 4096;
  const std::ptrdiff_t blocks = static_cast<std::ptrdiff_t>((n + kBlock - 1) / kBlock);
  std::mutex mutex;
#pragma omp parallel num_threads(thread_count)
  {
    Eigen::VectorXd local_sum = Eigen::VectorXd::Zero(c_count);
    Eigen::MatrixXd local_second = Eigen::MatrixXd::Zero(c_count, c_count);
    Eigen::MatrixXd y(c_count, kBlock);
#pragma omp for schedule(static)
    for (std::ptrdiff_t b = 0; b < blocks; ++b) {
      const std::size_t first = static_cast<std::size_t>(b) * kBlock, count = std::min(kBlock, n - first);
      for (std::size_t i = 0; i < count; ++i)
        for (int c = 0; c < c_count; ++c) y(c, i) = double(v[(first + i) * c_count + c]) * scale_[c];
      const auto block = y.leftCols(static_cast<Eigen::Index>(count));
      local_sum += block.rowwise().sum();
      // A rank update (no GEMM: Eigen's would spawn nested OpenMP threads here).
      local_second.selfadjointView<Eigen::Lower>().rankUpdate(block);
    }
    std::lock_guard lock(mutex);
    sum += local_sum, second += local_second;
  }
  const Eigen::VectorXd mean = sum / double(n);
  const Eigen::MatrixXd second_full = second.selfadjointView<Eigen::Lower>();
  const Eigen::MatrixXd covariance = second_full / double(n) - mean * mean.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(covariance);
  // Eigen sorts eigenvalues ascending: the leading axes are the last columns.
  const int kept = std::min(c_count, kDims);
  mean_.resize(c_count);
  for (int c = 0; c < c_count; ++c) mean_[c] = static_cast<float>(mean(c));
  axes_.assign(std::size_t(kDims) * c_count, 0.0f);
  double captured = 0;
  for (int k = 0; k < kept; ++k) {
    const int column = c_count - 1 - k;
    captured += std::max(eigen.eigenvalues()(column), 0.0);
    for (int c = 0; c < c_count; ++c) axes_[std::size_t(k) * c_count + c] = static_cast<float>(eigen.eigenvectors()(c, column));
  }
  const double total = std::max(covariance.trace(), 1e-300);
  captured_variance_ = kept == c_count ? 1.0 : std::min(captured / total, 1.0);
  off_subspace_rms_ = kept == c_count ? 0.0 : std::sqrt(std::max(total - captured, 0.0));

  values_.assign(n * kDims, 0.0f);
#pragma omp parallel for num_threads(thread_count) schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    float y[256];
    const float* node_values = v + std::size_t(i) * c_count;
    float* z = values_.data() + std::size_t(i) * kDims;
    for (int first = 0; first < c_count; first += 256) {
      const int count = std::min(256, c_count - first);
      for (int c = 0; c < count; ++c) y[c] = node_values[first + c] * scale_[first + c] - mean_[first + c];
      for (int k = 0; k < kept; ++k) {
        const float* axis = axes_.data() + std::size_t(k) * c_count + first;
        float s = 0;
        for (int c = 0; c < count; ++c) s += axis[c] * y[c];
        z[k] += s;
      }
    }
  }
  const std::size_t per_node = static_cast<std::size_t>(c_count);
  step_[0] = table_->node_offset(1, 0, 0, 0) / per_node, step_[1] = table_->node_offset(0, 1, 0, 0) / per_node;
  step_[2] = table_->node_offset(0, 0, 1, 0) / per_node, step_[3] = table_->node_offset(0, 0, 0, 1) / per_node;
}

std::shared_ptr<const SubspaceTable> SubspaceTable::shared(std::shared_ptr<const ForwardTable> table,
                                                           std::span<const double> reference_sigma, int threads) {
  if (!table) throw std::invalid_argument("subspace table: no forward table");
  files::Fnv1a h;
  h.add(table->key());
  for (double s : reference_sigma) {
    const long octave64 = std::isfinite(s) && s > 0 ? std::lround(64 * std::log2(s)) : 0;
    h.add(octave64);
  }
  static std::mutex mutex;
  static std::map<std::uint64_t, std::weak_ptr<const SubspaceTable>> registry;
  std::lock_guard lock(mutex);
  if (auto existing = registry[h.h].lock()) return existing;
  auto made = std::make_shared<const SubspaceTable>(std::move(table), reference_sigma, threads);
  registry[h.h] = made;
  return made;
}

void SubspaceTable::whiten(const double* measured, float* y) const {
  for (int c = 0; c < channels_; ++c) y[c] = static_cast<float>(measured[c]) * scale_[c] - mean_[c];
}

void SubspaceTable::project(const double* measured, float* z) const {
  std::fill_n(z, kDims, 0.0f);
  const int kept = std::min(channels_, kDims);
  for (int c = 0; c < channels_; ++c) {
    const float y = static_cast<float>(measured[c]) * scale_[c] - mean_[c];
    for (int k = 0; k < kept; ++k) z[k] += axes_[std::size_t(k) * channels_ + c] * y;
  }
}

// The 16 corners of the cell around x, one Float8 each: the value sums them
// weighted by the products of the axes' factors (1 − f, f); each derivative
// replaces its axis' factor by ∓1.
void SubspaceTable::predict(const float* x, float* value, float* jacobian) const {
  const detail::CellPosition cell = detail::cell_position(x, table_->nodes());
  const int* base = cell.base;
  const float* f = cell.fraction;
  const float* origin = node(node_index(base[0], base[1], base[2], base[3]));
  Float8 s = {}, d[4] = {};
  for (int corner = 0; corner < 16; ++corner) {
    float w[4], sign[4];
    std::size_t offset = 0;
    for (int k = 0; k < 4; ++k) {
      const bool upper = corner >> k & 1;
      w[k] = upper ? f[k] : 1 - f[k];
      sign[k] = upper ? 1.0f : -1.0f;
      if (upper) offset += step_[k];
    }
    Float8 node_z;
    std::memcpy(&node_z, origin + offset * kDims, sizeof node_z);
    const float w01 = w[0] * w[1], w23 = w[2] * w[3];
    s += (w01 * w23) * node_z;
    if (jacobian) {
      d[0] += (sign[0] * w[1] * w23) * node_z;
      d[1] += (sign[1] * w[0] * w23) * node_z;
      d[2] += (sign[2] * w[3] * w01) * node_z;
      d[3] += (sign[3] * w[2] * w01) * node_z;
    }
  }
  std::memcpy(value, &s, sizeof s);
  if (jacobian)
    for (int r = 0; r < kDims; ++r)
      for (int k = 0; k < 4; ++k) jacobian[r * 4 + k] = d[k][r];
}

}  // namespace chromo::estimation
