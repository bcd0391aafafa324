#include "chromo/estimation/appearance.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::estimation {

namespace {

// CIE: f(t) = t^(1/3) above (6/29)³, else the linear segment.
constexpr double kEpsilon = 216.0 / 24389.0;
constexpr double kLinearSlope = 24389.0 / 27.0 / 116.0;

// Cube root of t > 0 to double precision: an exponent-third bit guess (within
// a few per cent), then two Halley steps (cubic convergence: ~1e-5, then
// ~1e-15). std::cbrt was a third of the order rule's cost.
inline double cube_root(double t) {
  double y = std::bit_cast<double>(std::bit_cast<std::uint64_t>(t) / 3 + 0x2A9F7893782DA1CEull);
  for (int i = 0; i < 2; ++i) {
    const double y3 = y * y * y;
    y *= (y3 + 2 * t) / (2 * y3 + t);
  }
  return y;
}

// f and df/dt.
inline void lab_f(double t, double* f, double* df) {
  if (t > kEpsilon) {
    const double r = cube_root(t);
    *f = r;
    *df = 1.0 / (3.0 * r * r);
  } else {
    *f = kLinearSlope * t + 16.0 / 116.0;
    *df = kLinearSlope;
  }
}

}  // namespace

MeasurementSet AppearanceTable::reference_set() {
  const spectral::Observer& o = spectral::cie1931_observer();
  MeasurementSet set{spectral::CameraSensitivity{"CIE 1931 2°", {o.x_bar, o.y_bar, o.z_bar}}, {}};
  const char* names[3] = {".X", ".Y", ".Z"};
  for (const spectral::NamedIlluminant& i : spectral::relight_illuminants())
    for (int c = 0; c < 3; ++c) set.channels.push_back({i.name + names[c], i.spectrum, c, ChannelNoise{}});
  if (set.size() != kChannels)
    throw std::logic_error("appearance: relight_illuminants() has " + std::to_string(set.size() / 3) +
                           " illuminants, the table expects " + std::to_string(kIlluminants));
  return set;
}

AppearanceTable::AppearanceTable(std::shared_ptr<const ForwardTable> table, const TableGrid& measurement_grid)
    : table_(std::move(table)) {
  if (!table_ || table_->channels() != kChannels)
    throw std::invalid_argument("appearance table: needs a table of " + std::to_string(kChannels) +
                                " channels (X, Y, Z under the reference illuminants)");
  std::string error;
  if (!measurement_grid.IsValid(&error)) throw std::invalid_argument("appearance table: measurement grid: " + error);
  const std::array<int, 4> from = {measurement_grid.cm_nodes, measurement_grid.ch_nodes, measurement_grid.bm_nodes,
                                   measurement_grid.che_nodes};
  const std::array<int, 4> to = table_->nodes();
  for (int k = 0; k < 4; ++k) scale_[k] = (to[k] - 1.0) / (from[k] - 1.0);
}

std::shared_ptr<const AppearanceTable> AppearanceTable::load_or_build(const TableGrid& measurement_grid,
                                                                      const std::filesystem::path& cache_dir,
                                                                      int threads) {
  const std::filesystem::path dir = cache_dir.empty() ? ForwardTable::default_cache_dir() : cache_dir;
  return std::make_shared<const AppearanceTable>(
      ForwardTable::load_or_build(reference_set(), kGrid, dir, nullptr, threads), measurement_grid);
}

std::shared_ptr<const AppearanceTable> AppearanceTable::shared(const TableGrid& grid,
                                                               const std::filesystem::path& cache_dir) {
  static std::mutex mutex;
  static std::map<std::pair<std::string, std::string>, std::weak_ptr<const AppearanceTable>> held;
  const std::string grid_key = std::to_string(grid.cm_nodes) + "x" + std::to_string(grid.ch_nodes) + "x" +
                               std::to_string(grid.bm_nodes) + "x" + std::to_string(grid.che_nodes);
  std::lock_guard lock(mutex);
  std::weak_ptr<const AppearanceTable>& slot = held[{grid_key, cache_dir.string()}];
  if (auto table = slot.lock()) return table;
  auto table = load_or_build(grid, cache_dir);
  slot = table;
  return table;
}

void AppearanceTable::xyz(const GridPoint& x, double* xyz) const {
  const GridPoint own = {x[0] * scale_[0], x[1] * scale_[1], x[2] * scale_[2], x[3] * scale_[3]};
  table_->predict(own, xyz);
}

void AppearanceTable::at(const GridPoint& x, Point& out) const {
  double dxyz[kChannels * 4];
  const GridPoint own = {x[0] * scale_[0], x[1] * scale_[1], x[2] * scale_[2], x[3] * scale_[3]};
  table_->predict(own, out.xyz, dxyz);
  for (int l = 0; l < kIlluminants; ++l) {
    double f[3];
    double* df = out.f_slope + 3 * l;
    for (int i = 0; i < 3; ++i) lab_f(out.xyz[3 * l + i], &f[i], &df[i]);
    double* lab = out.lab + 3 * l;
    lab[0] = 116.0 * f[1] - 16.0;
    lab[1] = 500.0 * (f[0] - f[1]);
    lab[2] = 200.0 * (f[1] - f[2]);
    const double* dx = dxyz + 3 * l * 4;  // rows X, Y, Z of this illuminant
    double* j = out.jacobian + 3 * l * 4;
    for (int k = 0; k < 4; ++k) {
      const double fx = df[0] * dx[k] * scale_[k], fy = df[1] * dx[4 + k] * scale_[k], fz = df[2] * dx[8 + k] * scale_[k];
      j[k] = 116.0 * fy;
      j[4 + k] = 500.0 * (fx - fy);
      j[8 + k] = 200.0 * (fy - fz);
    }
  }
}

void AppearanceTable::lab(const GridPoint& x, double* lab, double* jacobian) const {
  Point p;
  at(x, p);
  std::copy_n(p.lab, kChannels, lab);
  if (jacobian) std::copy_n(p.jacobian, kChannels * 4, jacobian);
}

double AppearanceTable::linear_delta_e(const Point& from, const double* xyz, int l) {
  const double* df = from.f_slope + 3 * l;
  const double fx = df[0] * (xyz[3 * l] - from.xyz[3 * l]), fy = df[1] * (xyz[3 * l + 1] - from.xyz[3 * l + 1]),
               fz = df[2] * (xyz[3 * l + 2] - from.xyz[3 * l + 2]);
  const double dl = 116.0 * fy, da = 500.0 * (fx - fy), db = 200.0 * (fy - fz);
  return std::sqrt(dl * dl + da * da + db * db);
}

}  // namespace chromo::estimation
