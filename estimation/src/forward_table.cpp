#include "chromo/estimation/forward_table.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <stdexcept>

#include "chromo/estimation/skin_model.hpp"
#include "chromo/files/binary_cache.hpp"
#include "chromo/files/fnv1a.hpp"

namespace chromo::estimation {

namespace {

// Version 2: the file is a files/binary_cache.hpp file (version 1 had no
// payload length or checksum).
constexpr files::CacheFormat kForwardTableCacheFormat{{'C', 'H', 'R', 'O', 'M', 'O', 'F', 'T'}, 2};

struct Axis {
  double min, max;
  bool log;
};
constexpr std::array<Axis, 4> kAxes{Axis{kCmRange.min, kCmRange.max, true}, Axis{kChRange.min, kChRange.max, true},
                                    Axis{kBmRange.min, kBmRange.max, false},
                                    Axis{kCheRange.min, kCheRange.max, false}};

double axis_value(int axis, double x, int nodes) {
  const Axis& a = kAxes[axis];
  const double t = x / (nodes - 1);
  if (a.log) return a.min * std::pow(a.max / a.min, t);
  return a.min + (a.max - a.min) * t;
}

double axis_coordinate(int axis, double value, int nodes) {
  const Axis& a = kAxes[axis];
  double t = a.log ? std::log(std::max(value, 1e-12) / a.min) / std::log(a.max / a.min) : (value - a.min) / (a.max - a.min);
  if (!std::isfinite(t)) t = 0;
  return std::clamp(t, 0.0, 1.0) * (nodes - 1);
}

// As accumulate_corners, corner by corner: each corner's C contiguous values
// in the inner loop (vectorised), for wide tables (the AppearanceTable's 21
// channels, where the channel-outer loop gathered across corners and cost
// ×3-4 more).
template <int C>
void accumulate_corners_by_corner(const float* const* corner_values, const double* weight, const double (*dweight)[16],
                                  double* value, double* jacobian) {
  double v[C] = {}, d[4][C] = {};
  for (int corner = 0; corner < 16; ++corner) {
    const float* node = corner_values[corner];
    const double w = weight[corner];
    for (int c = 0; c < C; ++c) v[c] += w * node[c];
    if (!jacobian) continue;
    for (int k = 0; k < 4; ++k) {
      const double dk = dweight[k][corner];
      for (int c = 0; c < C; ++c) d[k][c] += dk * node[c];
    }
  }
  for (int c = 0; c < C; ++c) value[c] = v[c];
  if (jacobian)
    for (int c = 0; c < C; ++c)
      for (int k = 0; k < 4; ++k) jacobian[c * 4 + k] = d[k][c];
}

}  // namespace

bool TableGrid::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (cm_nodes < 2 || ch_nodes < 2 || bm_nodes < 2 || che_nodes < 2) return fail("every table axis needs >= 2 nodes");
  if ((bm_nodes - 1) % 10 != 0) return fail("bm_nodes must be 10k+1 so that the 2D model's βm = 0.7 is a node");
  if (node_count() > 50'000'000) return fail("table of " + std::to_string(node_count()) + " nodes is too large");
  return true;
}

double ForwardTable::node_value(int axis, int index) const { return axis_value(axis, index, nodes()[axis]); }

GridPoint ForwardTable::to_grid(const SkinParameters& p) const {
  const auto n = nodes();
  return {axis_coordinate(0, p.cm, n[0]), axis_coordinate(1, p.ch, n[1]), axis_coordinate(2, p.bm, n[2]),
          axis_coordinate(3, p.che, n[3])};
}

SkinParameters ForwardTable::from_grid(const GridPoint& x) const {
  const auto n = nodes();
  SkinParameters p;
  p.cm = axis_value(0, std::clamp(x[0], 0.0, n[0] - 1.0), n[0]);
  p.ch = axis_value(1, std::clamp(x[1], 0.0, n[1] - 1.0), n[1]);
  p.bm = axis_value(2, std::clamp(x[2], 0.0, n[2] - 1.0), n[2]);
  p.che = axis_value(3, std::clamp(x[3], 0.0, n[3] - 1.0), n[3]);
  return p;
}

namespace {

// Sums the 16 corners of a cell with precomputed weights: value = Σ w·v and,
// when jacobian is set, d value/d x_k = Σ dw_k·v. C is the channel count when
// known at compile time (the loops unroll and vectorise), 0 for any count.
template <int C>
void accumulate_corners(const float* const* corner_values, const double* weight, const double (*dweight)[16],
                        int channels, double* value, double* jacobian) {
  const int count = C > 0 ? C : channels;
  for (int c = 0; c < count; ++c) {
    double v = 0, d0 = 0, d1 = 0, d2 = 0, d3 = 0;
    for (int corner = 0; corner < 16; ++corner) {
      const double node = corner_values[corner][c];
      v += weight[corner] * node;
      if (jacobian) {
        d0 += dweight[0][corner] * node;
        d1 += dweight[1][corner] * node;
        d2 += dweight[2][corner] * node;
        d3 += dweight[3][corner] * node;
      }
    }
    value[c] = v;
    if (jacobian) jacobian[c * 4] = d0, jacobian[c * 4 + 1] = d1, jacobian[c * 4 + 2] = d2, jacobian[c * 4 + 3] = d3;
  }
}

}  // namespace

void ForwardTable::predict(const GridPoint& x, double* value, double* jacobian) const {
  const auto n = nodes();
  int base[4];
  double f[4];
  for (int k = 0; k < 4; ++k) {
    const double xc = std::clamp(std::isfinite(x[k]) ? x[k] : 0.0, 0.0, n[k] - 1.0);
    base[k] = std::min(static_cast<int>(xc), n[k] - 2);
    f[k] = xc - base[k];
  }
  // Corner weights as products of per-axis factors (1 − f, f), and their
  // derivatives along each axis (the factor of that axis replaced by ∓1).
  double weight[16], dweight[4][16];
  const float* corner_values[16];
  const std::size_t step[4] = {node_offset(1, 0, 0, 0), node_offset(0, 1, 0, 0), node_offset(0, 0, 1, 0),
                               node_offset(0, 0, 0, 1)};
  const float* origin = node(base[0], base[1], base[2], base[3]);
  for (int corner = 0; corner < 16; ++corner) {
    double w[4], s[4];
    std::size_t offset = 0;
    for (int k = 0; k < 4; ++k) {
      const bool upper = corner >> k & 1;
      w[k] = upper ? f[k] : 1.0 - f[k];
      s[k] = upper ? 1.0 : -1.0;
      if (upper) offset += step[k];
    }
    corner_values[corner] = origin + offset;
    const double w01 = w[0] * w[1], w23 = w[2] * w[3];
    weight[corner] = w01 * w23;
    dweight[0][corner] = s[0] * w[1] * w23;
    dweight[1][corner] = s[1] * w[0] * w23;
    dweight[2][corner] = s[2] * w[3] * w01;
    dweight[3][corner] = s[3] * w[2] * w01;
  }
  switch (channels_) {
    case 3: return accumulate_corners<3>(corner_values, weight, dweight, 3, value, jacobian);
    case 4: return accumulate_corners<4>(corner_values, weight, dweight, 4, value, jacobian);
    case 6: return accumulate_corners<6>(corner_values, weight, dweight, 6, value, jacobian);
    case 9: return accumulate_corners<9>(corner_values, weight, dweight, 9, value, jacobian);  // maps::RelitTable of three photographs
    case 12: return accumulate_corners_by_corner<12>(corner_values, weight, dweight, value, jacobian);
    case 18: return accumulate_corners_by_corner<18>(corner_values, weight, dweight, value, jacobian);  // six LEDs
    case 21: return accumulate_corners_by_corner<21>(corner_values, weight, dweight, value, jacobian);  // AppearanceTable
    case 24: return accumulate_corners_by_corner<24>(corner_values, weight, dweight, value, jacobian);
    case 27: return accumulate_corners_by_corner<27>(corner_values, weight, dweight, value, jacobian);  // six LEDs + method
    default: return accumulate_corners<0>(corner_values, weight, dweight, channels_, value, jacobian);
  }
}

std::uint64_t ForwardTable::cache_key(const MeasurementSet& set, const TableGrid& grid) {
  files::Fnv1a h;
  h.add(kForwardTableCacheFormat.magic);
  h.add(kForwardTableCacheFormat.version);
  h.add(grid.cm_nodes), h.add(grid.ch_nodes), h.add(grid.bm_nodes), h.add(grid.che_nodes);
  for (const Axis& a : kAxes) h.add(a.min), h.add(a.max), h.add(a.log);
  const Eigen::MatrixXd w = set.weights();
  h.add(w.data(), sizeof(double) * w.size());
  // The model itself: its albedo at probe parameters changes with any change
  // to its code, constants or data.
  const SkinModel model;
  for (const SkinParameters& p : {SkinParameters{0.01, 0.01, 0.3, 0.02}, SkinParameters{0.2, 0.1, 0.9, 0.08}}) {
    const spectral::Spectrum a = model.albedo(p);
    h.add(a.values().data(), sizeof(double) * spectral::kGridSize);
  }
  return h.h;
}

ForwardTable ForwardTable::build(const MeasurementSet& set, const TableGrid& grid, int threads) {
  std::string error;
  if (!grid.IsValid(&error)) throw std::invalid_argument("table grid: " + error);
  set.validate();
  ForwardTable t;
  t.grid_ = grid;
  t.channels_ = set.size();
  t.key_ = cache_key(set, grid);
  t.values_.assign(grid.node_count() * t.channels_, 0.0f);
  const Eigen::MatrixXd weights = set.weights();  // C × 81
  const SkinModel model;

  // Dermis: one dipole evaluation per Ch node (epidermis parameters do not matter).
  Eigen::MatrixXd r2(spectral::kGridSize, grid.ch_nodes);
  for (int i = 0; i < grid.ch_nodes; ++i)
    r2.col(i) = model.layers({0.01, t.node_value(1, i), 0.5, 0.0}).dermis_reflectance.values().matrix();

  const int epi_count = grid.cm_nodes * grid.bm_nodes * grid.che_nodes;
  const int thread_count = threads > 0 ? threads : omp_get_num_procs();
#pragma omp parallel num_threads(thread_count)
  {
    Eigen::MatrixXd albedo(spectral::kGridSize, grid.ch_nodes);
    Eigen::MatrixXd projected(t.channels_, grid.ch_nodes);
#pragma omp for schedule(dynamic, 8)
    for (int e = 0; e < epi_count; ++e) {
      const int i_cm = e % grid.cm_nodes;
      const int i_che = (e / grid.cm_nodes) % grid.che_nodes;
      const int i_bm = e / (grid.cm_nodes * grid.che_nodes);
      const LayerSpectra layers =
          model.layers({t.node_value(0, i_cm), 0.01, t.node_value(2, i_bm), t.node_value(3, i_che)});
      const spectral::GridArray& r1 = layers.epidermis_reflectance.values();
      const spectral::GridArray& t1 = layers.epidermis_transmittance.values();
      for (int i = 0; i < grid.ch_nodes; ++i) {
        const spectral::GridArray r2i = r2.col(i).array();
        albedo.col(i) = (r1 + t1 * r2i * t1 / (1.0 - r1 * r2i)).matrix();
      }
      projected.noalias() = weights.lazyProduct(albedo);  // coefficient-wise: no GEMM packing for a 4×81 by 81×n product
      float* out = t.values_.data() + t.node_offset(i_cm, 0, i_bm, i_che);
      for (int i = 0; i < grid.ch_nodes; ++i)
        for (int c = 0; c < t.channels_; ++c) out[i * t.channels_ + c] = static_cast<float>(projected(c, i));
    }
  }
  return t;
}

std::filesystem::path ForwardTable::default_cache_dir() {
  if (const char* d = std::getenv("CHROMO_CACHE_DIR"); d && *d) return d;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) return std::filesystem::path(d) / "chromosphere";
  if (const char* d = std::getenv("HOME"); d && *d) return std::filesystem::path(d) / ".cache" / "chromosphere";
  return std::filesystem::temp_directory_path() / "chromosphere-cache";
}

std::shared_ptr<const ForwardTable> ForwardTable::load_or_build(const MeasurementSet& set, const TableGrid& grid,
                                                                 const std::filesystem::path& cache_dir, bool* rebuilt,
                                                                 int threads) {
  std::string error;
  if (!grid.IsValid(&error)) throw std::invalid_argument("table grid: " + error);
  set.validate();
  const std::uint64_t key = cache_key(set, grid);
  const std::filesystem::path file = cache_dir / files::cache_file_name("forward_table", key);
  const std::int32_t dims[5] = {grid.cm_nodes, grid.ch_nodes, grid.bm_nodes, grid.che_nodes, set.size()};
  if (const auto payload = files::read_cache(file, kForwardTableCacheFormat, key)) {
    // Payload: the five dimensions (int32), then the values (float).
    files::CacheReader in(*payload);
    std::int32_t stored_dims[5];
    in.get_bytes(stored_dims, sizeof stored_dims);
    if (in.ok() && std::equal(std::begin(dims), std::end(dims), std::begin(stored_dims))) {
      auto t = std::make_shared<ForwardTable>();
      t->grid_ = grid;
      t->channels_ = set.size();
      t->key_ = key;
      t->values_.resize(grid.node_count() * t->channels_);
      in.get_bytes(t->values_.data(), t->values_.size() * sizeof(float));
      if (in.at_end()) {
        if (rebuilt) *rebuilt = false;
        return t;
      }
    }
  }
  auto t = std::make_shared<ForwardTable>(build(set, grid, threads));
  if (rebuilt) *rebuilt = true;
  files::CacheWriter out;
  out.reserve(sizeof dims + t->values_.size() * sizeof(float));
  out.put_bytes(dims, sizeof dims);
  out.put_bytes(t->values_.data(), t->values_.size() * sizeof(float));
  try {
    files::write_cache(file, kForwardTableCacheFormat, key, out.take_bytes());
  } catch (const std::exception&) {
    // A cache that cannot be written is not an error: the table is in memory.
  }
  return t;
}

}  // namespace chromo::estimation
