// InverseTable::build (inverse_table.hpp): the occupied cells' branches, the
// empty cells' fill and their own pre-solved branches, and every cell's 2D
// fit. Settings, key space, lookup and the cache file: inverse_table.cpp.
#include "chromo/estimation/inverse_table.hpp"

#include <omp.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <unordered_map>

#include "chromo/estimation/inverter.hpp"
#include "inverse_table_internal.hpp"

namespace chromo::estimation {

using namespace detail;

namespace {

// Inverse of inverse_table_key: a value whose key is `key`.
float value_of_key(float key) {
  const float bits_f = (key + 127.0f) * 8388608.0f;
  const auto bits = static_cast<std::uint32_t>(std::clamp(bits_f, 0.0f, 2139095039.0f));
  float v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

struct NodeIndex {
  int n[4];  // nodes along Cm, Ch, βm, Che
  // Node index i of the table's layout (values + i·C): ((bm·Nche + che)·Ncm + cm)·Nch + ch.
  void decode(std::uint32_t i, int* at) const {
    at[1] = static_cast<int>(i % n[1]);
    at[0] = static_cast<int>(i / n[1] % n[0]);
    at[3] = static_cast<int>(i / (n[1] * n[0]) % n[3]);
    at[2] = static_cast<int>(i / (n[1] * n[0] * n[3]));
  }
  std::uint32_t encode(const int* at) const {
    return static_cast<std::uint32_t>(((at[2] * n[3] + at[3]) * n[0] + at[0]) * n[1] + at[1]);
  }
};

int find_root(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// The weighted least-squares inverse of the 4×4 Jacobian (row-major dm/dx):
// jinv = (W·J_free)⁺·W, W = diag(weight), J_free = J without the columns of
// the held coordinates (their rows of jinv are zero: x0 + jinv·(m − m0) is the
// least-squares step along the bound face they sit on), singular values below
// 1/kMaxCondition of the largest dropped. All zero when J is zero.
void pseudo_inverse(const double* jacobian, const double* weight, const bool* held, float* jinv) {
  Eigen::Matrix4d j = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(jacobian);
  for (int k = 0; k < 4; ++k)
    if (held[k]) j.col(k).setZero();
  const Eigen::Vector4d w(weight[0], weight[1], weight[2], weight[3]);
  const Eigen::Matrix4d weighted = w.asDiagonal() * j;
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(weighted, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  if (!(sv[0] > 0)) return;
  Eigen::Vector4d inverse_sv = Eigen::Vector4d::Zero();
  for (int k = 0; k < 4; ++k)
    if (sv[k] > sv[0] / kMaxCondition) inverse_sv[k] = 1 / sv[k];
  const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> inverse =
      svd.matrixV() * inverse_sv.asDiagonal() * svd.matrixU().transpose() * w.asDiagonal();
  for (int k = 0; k < 16; ++k) jinv[k] = held[k / 4] ? 0.0f : static_cast<float>(inverse.data()[k]);  // exactly zero
}

// Branches of one cell: LM from the best node of each grid-connected group of
// the cell's bucket towards the measurement at the cell centre.
std::vector<InverseTable::Branch> solve_cell(const Inverter& solver, const NodeIndex& index,
                                             const std::uint32_t* nodes, std::uint32_t count, const double* centre) {
  const ForwardTable& table = solver.table();
  const int channels = table.channels();
  ChannelBuffer<double> weight(channels);
  for (int c = 0; c < channels; ++c) weight[c] = 1.0 / (0.01 * std::max(centre[c], 1e-4));
  // Groups: union of axis neighbours within the bucket (nodes are sorted).
  std::vector<int> parent(count);
  std::iota(parent.begin(), parent.end(), 0);
  for (std::uint32_t k = 0; k < count; ++k) {
    int at[4];
    index.decode(nodes[k], at);
    for (int axis = 0; axis < 4; ++axis) {
      if (at[axis] + 1 >= index.n[axis]) continue;
      int next[4] = {at[0], at[1], at[2], at[3]};
      ++next[axis];
      const std::uint32_t neighbour = index.encode(next);
      const std::uint32_t* found = std::lower_bound(nodes, nodes + count, neighbour);
      if (found != nodes + count && *found == neighbour) {
        const int a = find_root(parent, static_cast<int>(k)), b = find_root(parent, static_cast<int>(found - nodes));
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
      }
    }
  }
  // Best node of each group by χ² at the centre.
  std::map<int, std::pair<double, std::uint32_t>> best_of_group;
  for (std::uint32_t k = 0; k < count; ++k) {
    const float* v = table.values().data() + static_cast<std::size_t>(nodes[k]) * channels;
    double chi2 = 0;
    for (int c = 0; c < channels; ++c) chi2 += std::pow((v[c] - centre[c]) * weight[c], 2);
    auto [it, inserted] = best_of_group.try_emplace(find_root(parent, static_cast<int>(k)), chi2, nodes[k]);
    if (!inserted && chi2 < it->second.first) it->second = {chi2, nodes[k]};
  }
  std::vector<std::pair<double, std::uint32_t>> seeds;
  for (const auto& [group, seed] : best_of_group) seeds.push_back(seed);
  std::sort(seeds.begin(), seeds.end());
  if (seeds.size() > kMaxSeedsPerCell) seeds.resize(kMaxSeedsPerCell);

  std::vector<Fit> solutions;
  for (const auto& [chi2, node] : seeds) {
    int at[4];
    index.decode(node, at);
    const Fit f = solver.refine(centre, weight, 4, {double(at[0]), double(at[1]), double(at[2]), double(at[3])},
                                kBranchIterations);
    bool known = false;
    for (Fit& s : solutions) {
      double distance = 0;
      for (int k = 0; k < 4; ++k) distance = std::max(distance, std::abs(s.x[k] - f.x[k]));
      if (distance < kSameBranch) {
        known = true;
        if (f.chi2 < s.chi2) s = f;
        break;
      }
    }
    if (!known) solutions.push_back(f);
  }
  std::sort(solutions.begin(), solutions.end(), [](const Fit& a, const Fit& b) { return a.chi2 < b.chi2; });
  std::vector<InverseTable::Branch> branches;
  for (const Fit& s : solutions) {
    if (s.chi2 > solutions.front().chi2 + kBranchChi2Margin) break;
    if (static_cast<int>(branches.size()) == InverseTable::kMaxBranches) break;
    InverseTable::Branch b{};
    ChannelBuffer<double> m0(table.channels()), jacobian(std::size_t(table.channels()) * 4);
    table.predict(s.x, m0, jacobian);
    for (int k = 0; k < 4; ++k) b.x0[k] = static_cast<float>(s.x[k]);
    for (int c = 0; c < std::min(channels, 4); ++c) b.m0[c] = static_cast<float>(m0[c]);
    if (channels == 4) {
      // Pseudo-inverse without the directions the channels barely see (a
      // parameter that hardly changes the colour there): the linear step
      // leaves them to Gauss-Newton.
      const double unit[4] = {1, 1, 1, 1};
      const bool held[4] = {};
      pseudo_inverse(jacobian, unit, held, b.jinv);
    }
    branches.push_back(b);
  }
  return branches;
}

// Weights of a pre-solved fit at `centre`: σ_c = 1% of the value times the
// channel's relative noise.
void presolve_weights(const double* centre, const std::array<double, 4>& relative_sigma, double* weight) {
  for (int c = 0; c < 4; ++c) weight[c] = 1.0 / (0.01 * relative_sigma[c] * std::max(centre[c], 1e-4));
}

// The 2D model's fit at `centre` (4 channels): the best slice node, LM, and
// the weighted pseudo-inverse along the slice (βm and Che rows zero; a Cm or
// Ch held at a bound its gradient points out of, as for the empty cells).
std::optional<InverseTable::Branch> solve_slice(const ExhaustiveInverter& solver, const double* centre,
                                                const double* weight) {
  const ForwardTable& table = solver.table();
  Fit f = solver.fit(centre, weight, 2);
  const Fit polished = solver.refine(centre, weight, 2, f.x, kBranchIterations);
  if (polished.chi2 < f.chi2) f = polished;
  if (!std::isfinite(f.chi2)) return std::nullopt;
  ChannelBuffer<double> m0(table.channels()), jacobian(std::size_t(table.channels()) * 4);
  table.predict(f.x, m0, jacobian);
  InverseTable::Branch b{};
  bool held[4] = {false, false, true, true};
  for (int k = 0; k < 4; ++k) {
    b.x0[k] = static_cast<float>(f.x[k]);
    b.m0[k] = static_cast<float>(m0[k]);
  }
  for (int k = 0; k < 2; ++k) {
    double gradient = 0;  // of χ²/2 along x_k
    for (int c = 0; c < 4; ++c) gradient += jacobian[c * 4 + k] * weight[c] * weight[c] * (m0[c] - centre[c]);
    held[k] = (f.x[k] <= 0 && gradient > 0) || (f.x[k] >= table.nodes()[k] - 1 && gradient < 0);
  }
  pseudo_inverse(jacobian, weight, held, b.jinv);
  return b;
}

}  // namespace

InverseTable InverseTable::build(std::shared_ptr<const ForwardTable> table_ptr, int threads,
                                 const InverseTableSettings& settings) {
  if (!table_ptr || table_ptr->values().empty()) throw std::invalid_argument("inverse table: empty forward table");
  const ForwardTable& table = *table_ptr;
  InverseTable t;
  t.key_ = cache_key(table, settings);
  const int channels = table.channels();
  t.key_channels_ = channels;
  t.key_dims_ = std::min(channels, kMaxKeyDims);
  const std::size_t node_count = table.grid().node_count();
  const std::vector<float>& v = table.values();
  const int dims = t.key_dims_;
  // Per-channel whitening (more than four channels: 1/relative σ).
  t.key_whiten_.assign(channels, 1.0f);
  if (channels > kMaxKeyDims) {
    const std::vector<double> sigma = settings.quantised_channel_sigma(channels);
    for (int c = 0; c < channels; ++c) t.key_whiten_[c] = static_cast<float>(1.0 / sigma[c]);
  }
  // Principal axes of the nodes' (whitened) pseudo-log keys.
  if (channels <= kMaxKeyDims) {
    Eigen::Vector4d mean = Eigen::Vector4d::Zero();
    Eigen::Matrix4d second = Eigen::Matrix4d::Zero();
    for (std::size_t i = 0; i < node_count; ++i) {
      Eigen::Vector4d k = Eigen::Vector4d::Zero();
      for (int d = 0; d < dims; ++d) k[d] = inverse_table_key(v[i * channels + d]);
      mean += k;
      second += k * k.transpose();
    }
    mean /= double(node_count);
    const Eigen::Matrix4d covariance = second / double(node_count) - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(covariance.topLeftCorner(dims, dims));
    t.key_mean_.assign(channels, 0.0f);
    t.key_axes_.assign(std::size_t(dims) * channels, 0.0f);
    for (int d = 0; d < dims; ++d) t.key_mean_[d] = static_cast<float>(mean[d]);
    for (int a = 0; a < dims; ++a)  // largest variance first
      for (int d = 0; d < dims; ++d)
        t.key_axes_[a * channels + d] = static_cast<float>(solver.eigenvectors()(d, dims - 1 - a));
  } else {
    // The measurement's principal subspace: the kMaxKeyDims leading axes of
    // the whitened keys' covariance (accumulated in blocks of nodes).
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(channels);
    Eigen::MatrixXd second = Eigen::MatrixXd::Zero(channels, channels);
    constexpr std::size_t kBlock = 4096;
    Eigen::MatrixXd block(channels, kBlock);
    for (std::size_t first = 0; first < node_count; first += kBlock) {
      const std::size_t count = std::min(kBlock, node_count - first);
      for (std::size_t i = 0; i < count; ++i)
        for (int c = 0; c < channels; ++c)
          block(c, Eigen::Index(i)) = inverse_table_key(v[(first + i) * channels + c]) * t.key_whiten_[c];
      const auto used = block.leftCols(Eigen::Index(count));
      mean += used.rowwise().sum();
      second.noalias() += used * used.transpose();
    }
    mean /= double(node_count);
    const Eigen::MatrixXd covariance = second / double(node_count) - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(covariance);
    t.key_mean_.resize(channels);
    for (int c = 0; c < channels; ++c) t.key_mean_[c] = static_cast<float>(mean[c]);
    t.key_axes_.assign(std::size_t(dims) * channels, 0.0f);
    double captured = 0;
    for (int a = 0; a < dims; ++a) {
      captured += solver.eigenvalues()[channels - 1 - a];
      for (int c = 0; c < channels; ++c)
        t.key_axes_[a * channels + c] = static_cast<float>(solver.eigenvectors()(c, channels - 1 - a));
    }
    // The key's centring folds into the mean: key = axes · (whitened − mean).
    t.captured_variance_ = captured / std::max(solver.eigenvalues().sum(), 1e-300);
  }
  std::vector<float> keys(node_count * dims);
  for (std::size_t i = 0; i < node_count; ++i) t.key_of(v.data() + i * channels, keys.data() + i * dims);
  for (int k = 0; k < dims; ++k) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (std::size_t i = 0; i < node_count; ++i) lo = std::min(lo, keys[i * dims + k]), hi = std::max(hi, keys[i * dims + k]);
    t.key_min_[k] = lo;
    t.key_scale_[k] = static_cast<float>((kBins - 1e-3) / std::max(double(hi) - lo, 1e-9));
  }
  std::uint32_t box_cells = 1;
  for (int k = 0; k < dims; ++k) box_cells *= kBins;
  // Box cell of every node, then occupied cells numbered in box order and
  // the nodes sorted by cell (counting sort: ascending node index per cell).
  std::vector<std::uint32_t> box_of_node(node_count);
  t.cell_index_.assign(box_cells, kNoCell);
  std::vector<std::uint32_t> count_of_box(box_cells, 0);
  for (std::size_t i = 0; i < node_count; ++i) {
    std::uint32_t box = 0, stride = 1;
    for (int k = 0; k < dims; ++k, stride *= kBins) {
      const float position = (keys[i * dims + k] - t.key_min_[k]) * t.key_scale_[k];
      box += static_cast<std::uint32_t>(std::clamp(static_cast<int>(position), 0, kBins - 1)) * stride;
    }
    box_of_node[i] = box;
    ++count_of_box[box];
  }
  std::uint32_t begin = 0;
  for (std::uint32_t box = 0; box < box_cells; ++box) {
    if (!count_of_box[box]) continue;
    t.cell_index_[box] = static_cast<std::uint32_t>(t.cells_.size());
    Cell c;
    c.bucket_begin = begin;
    c.bucket_count = count_of_box[box];
    begin += c.bucket_count;
    t.cells_.push_back(c);
  }
  t.bucket_nodes_.resize(node_count);
  {
    std::vector<std::uint32_t> fill(t.cells_.size(), 0);
    for (std::size_t i = 0; i < node_count; ++i) {
      const std::uint32_t cell = t.cell_index_[box_of_node[i]];
      t.bucket_nodes_[t.cells_[cell].bucket_begin + fill[cell]++] = static_cast<std::uint32_t>(i);
    }
  }
  const std::size_t occupied = t.cells_.size();
  t.occupied_cells_ = occupied;

  // Branches per occupied cell, in parallel; then concatenated in cell order.
  const ExhaustiveInverter solver(table_ptr);
  const NodeIndex index{{table.nodes()[0], table.nodes()[1], table.nodes()[2], table.nodes()[3]}};
  std::vector<std::vector<Branch>> per_cell(occupied);
  const bool with_slice = channels == 4;
  const std::array<double, 4> relative_sigma = settings.quantised_sigma();
  std::vector<std::optional<Branch>> slice_of_cell(occupied);
  std::vector<std::uint32_t> box_of_cell(occupied);
  for (std::uint32_t box = 0; box < box_cells; ++box)
    if (t.cell_index_[box] != kNoCell) box_of_cell[t.cell_index_[box]] = box;
  const int thread_count = threads > 0 ? threads : omp_get_num_procs();
  // Branches in key space need a cell centre in measurement space: tables of
  // more than four channels (a key of fewer dimensions) hold buckets only.
  const std::ptrdiff_t solved_cells = channels <= kMaxKeyDims ? static_cast<std::ptrdiff_t>(occupied) : 0;
#pragma omp parallel for num_threads(thread_count) schedule(dynamic, 64)
  for (std::ptrdiff_t cell = 0; cell < solved_cells; ++cell) {
    double centre[kMaxKeyDims] = {};
    std::array<float, 4> bin{};
    std::uint32_t box = box_of_cell[cell];
    for (int k = 0; k < dims; ++k, box /= kBins) bin[k] = static_cast<float>(box % kBins);
    const std::array<double, 4> key_centre = t.box_centre(bin);
    std::copy_n(key_centre.begin(), dims, centre);
    const Cell& c = t.cells_[cell];
    per_cell[cell] = solve_cell(solver, index, t.bucket_nodes_.data() + c.bucket_begin, c.bucket_count, centre);
    if (with_slice) {
      double weight[4];
      presolve_weights(centre, relative_sigma, weight);
      slice_of_cell[cell] = solve_slice(solver, centre, weight);
    }
  }
  for (std::size_t cell = 0; cell < occupied; ++cell) {
    t.cells_[cell].branch_begin = static_cast<std::uint32_t>(t.branches_.size());
    t.cells_[cell].branch_count = static_cast<std::uint32_t>(per_cell[cell].size());
    t.branches_.insert(t.branches_.end(), per_cell[cell].begin(), per_cell[cell].end());
  }
  for (std::size_t cell = 0; cell < occupied; ++cell)
    if (slice_of_cell[cell])
      t.cells_[cell].slice_branch = static_cast<std::uint32_t>(t.branches_.size()), t.branches_.push_back(*slice_of_cell[cell]);

  const std::vector<std::uint32_t> own_cell_index = t.cell_index_;
  // Empty cells point at the nearest occupied cell along one axis: up to
  // kFillReach[a] bins along axis a, thinnest axis first (a noisy pixel lies
  // off the thin gamut sheet by many bins of its thin axes; Gauss-Newton from
  // the neighbouring branches then finds its bounded least-squares fit).
  std::uint32_t stride = 1;
  for (int k = 0; k < dims; ++k) stride *= kBins;
  for (int axis = dims - 1; axis >= 0; --axis) {
    stride /= kBins;
    const int reach = kFillReach[axis];
    std::vector<std::uint32_t> next = t.cell_index_;
    for (std::uint32_t line = 0; line < box_cells; ++line) {
      if (line / stride % kBins != 0) continue;  // first cell of a line along this axis
      int last = -1000;
      for (int i = 0; i < kBins; ++i) {  // forward: nearest occupied before
        const std::uint32_t box = line + i * stride;
        if (t.cell_index_[box] != kNoCell) last = i;
        else if (i - last <= reach) next[box] = t.cell_index_[line + last * stride];
      }
      last = 1000;
      for (int i = kBins - 1; i >= 0; --i) {  // backward: nearer occupied after
        const std::uint32_t box = line + i * stride;
        if (t.cell_index_[box] != kNoCell) {
          last = i;
          continue;
        }
        if (last - i > reach) continue;
        int before = -1000;
        for (int j = i - 1; j >= 0 && i - j <= reach; --j)
          if (t.cell_index_[line + j * stride] != kNoCell) { before = j; break; }
        if (last - i < i - before) next[box] = t.cell_index_[line + last * stride];
      }
    }
    t.cell_index_.swap(next);
  }
  if (channels == 4 && settings.presolve_empty_cells)
    t.presolve_empty_cells(table_ptr, own_cell_index, relative_sigma, thread_count);
  return t;
}

std::array<double, 4> InverseTable::box_centre(std::array<float, 4> bin) const {
  float rotated[4] = {};
  for (int k = 0; k < key_dims_; ++k) rotated[k] = key_min_[k] + (bin[k] + 0.5f) / key_scale_[k];
  std::array<double, 4> centre{};
  for (int d = 0; d < key_dims_; ++d) {
    float key = key_mean_[d];
    for (int a = 0; a < key_dims_; ++a) key += key_axes_[a * key_channels_ + d] * rotated[a];
    centre[d] = value_of_key(key);
  }
  return centre;
}

void InverseTable::presolve_empty_cells(std::shared_ptr<const ForwardTable> table_ptr,
                                        const std::vector<std::uint32_t>& own_cell_index,
                                        const std::array<double, 4>& relative_sigma, int threads) {
  const ForwardTable& table = *table_ptr;
  // Blocks of empty cells that the fill reached, numbered in box order.
  int block_bins[4], blocks_per_axis[4];
  std::uint32_t block_count = 1;
  for (int a = 0; a < 4; ++a) {
    block_bins[a] = kPresolveBlock[a];
    blocks_per_axis[a] = (kBins + block_bins[a] - 1) / block_bins[a];
    block_count *= blocks_per_axis[a];
  }
  auto block_of = [&](std::uint32_t box) {
    std::uint32_t block = 0, stride = 1;
    for (int a = 0; a < 4; ++a) {
      block += (box % kBins) / block_bins[a] * stride;
      box /= kBins;
      stride *= blocks_per_axis[a];
    }
    return block;
  };
  std::vector<std::uint32_t> slot_of_block(block_count, kNoCell), block_of_slot;
  for (std::uint32_t box = 0; box < cell_index_.size(); ++box) {
    if (own_cell_index[box] != kNoCell || cell_index_[box] == kNoCell) continue;
    const std::uint32_t block = block_of(box);
    std::uint32_t& slot = slot_of_block[block];
    if (slot == kNoCell) slot = static_cast<std::uint32_t>(block_of_slot.size()), block_of_slot.push_back(block);
  }
  // One bounded fit per block at its centre, by the fast inverter on the
  // occupied cells' branches (and its search path), polished by LM.
  const auto stage_one = std::make_shared<const InverseTable>(*this);
  const FastInverter fast(table_ptr, stage_one);
  const std::array<float, 4> upper = {float(table.nodes()[0] - 1), float(table.nodes()[1] - 1),
                                      float(table.nodes()[2] - 1), float(table.nodes()[3] - 1)};
  const ExhaustiveInverter slice_solver(table_ptr);
  std::vector<Branch> solved(block_of_slot.size());
  std::vector<std::optional<Branch>> slice_of_slot(block_of_slot.size());
  std::vector<char> has_solution(block_of_slot.size(), 0);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256)
  for (std::ptrdiff_t slot = 0; slot < static_cast<std::ptrdiff_t>(block_of_slot.size()); ++slot) {
    std::array<float, 4> bin;  // the block's central bin (fractional)
    std::uint32_t block = block_of_slot[slot];
    for (int a = 0; a < 4; ++a) {
      const int first = static_cast<int>(block % blocks_per_axis[a]) * block_bins[a];
      const int last = std::min(first + block_bins[a], kBins) - 1;
      bin[a] = 0.5f * static_cast<float>(first + last);
      block /= blocks_per_axis[a];
    }
    const std::array<double, 4> centre = box_centre(bin);
    double weight[4];  // σ = 1% of the value for the least noisy channel
    presolve_weights(centre.data(), relative_sigma, weight);
    slice_of_slot[slot] = solve_slice(slice_solver, centre.data(), weight);
    Fit f = fast.fit(centre.data(), weight, 4);
    const Fit polished = fast.refine(centre.data(), weight, 4, f.x, kBranchIterations);
    if (polished.chi2 < f.chi2) f = polished;
    if (!std::isfinite(f.chi2)) continue;
    ChannelBuffer<double> m0(table.channels()), jacobian(std::size_t(table.channels()) * 4);
    table.predict(f.x, m0, jacobian);
    Branch& b = solved[slot];
    bool held[4];
    for (int k = 0; k < 4; ++k) {
      b.x0[k] = static_cast<float>(f.x[k]);
      b.m0[k] = static_cast<float>(m0[k]);
      double gradient = 0;  // of χ²/2 along x_k
      for (int c = 0; c < 4; ++c) gradient += jacobian[c * 4 + k] * weight[c] * weight[c] * (m0[c] - centre[c]);
      held[k] = (f.x[k] <= 0 && gradient > 0) || (f.x[k] >= upper[k] && gradient < 0);
    }
    pseudo_inverse(jacobian, weight, held, b.jinv);
    has_solution[slot] = 1;
  }
  // Every reached empty cell: a cell of its own with its neighbour's bucket
  // (the search path's seeds, as before) and its block's branch; one such
  // cell per (block, neighbour) pair.
  std::vector<std::uint32_t> branch_of_slot(block_of_slot.size(), kNoCell), slice_branch_of_slot(block_of_slot.size(), kNoCell);
  for (std::size_t slot = 0; slot < block_of_slot.size(); ++slot)
    if (has_solution[slot]) branch_of_slot[slot] = static_cast<std::uint32_t>(branches_.size()), branches_.push_back(solved[slot]);
  for (std::size_t slot = 0; slot < block_of_slot.size(); ++slot)
    if (has_solution[slot] && slice_of_slot[slot])
      slice_branch_of_slot[slot] = static_cast<std::uint32_t>(branches_.size()), branches_.push_back(*slice_of_slot[slot]);
  std::unordered_map<std::uint64_t, std::uint32_t> cell_of_pair;
  for (std::uint32_t box = 0; box < cell_index_.size(); ++box) {
    if (own_cell_index[box] != kNoCell || cell_index_[box] == kNoCell) continue;
    const std::uint32_t slot = slot_of_block[block_of(box)];
    if (branch_of_slot[slot] == kNoCell) continue;
    const std::uint32_t neighbour = cell_index_[box];
    auto [it, inserted] = cell_of_pair.try_emplace((std::uint64_t(slot) << 32) | neighbour, std::uint32_t(cells_.size()));
    if (inserted) {
      Cell c = cells_[neighbour];
      c.presolved_branch = branch_of_slot[slot];
      if (slice_branch_of_slot[slot] != kNoCell) c.slice_branch = slice_branch_of_slot[slot];
      cells_.push_back(c);
    }
    cell_index_[box] = it->second;
  }
}

}  // namespace chromo::estimation
