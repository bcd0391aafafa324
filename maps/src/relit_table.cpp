#include "chromo/maps/relit_table.hpp"

#include <stdexcept>
#include <string>

namespace chromo::maps {

RelitTable::RelitTable(const spectral::CameraSensitivity& camera, std::span<const spectral::Spectrum> illuminants,
                       const estimation::TableGrid& grid, const std::filesystem::path& cache_dir, int threads)
    : illuminants_(illuminants.size()) {
  if (illuminants.empty()) throw std::invalid_argument("relit table: no illuminant");
  estimation::MeasurementSet set;
  set.camera = camera;
  for (std::size_t i = 0; i < illuminants.size(); ++i)
    for (int c = 0; c < 3; ++c)
      set.channels.push_back({"illuminant" + std::to_string(i) + "." + "RGB"[c], illuminants[i], c, {}});
  if (cache_dir.empty()) {
    table_ = std::make_shared<const estimation::ForwardTable>(estimation::ForwardTable::build(set, grid, threads));
  } else {
    table_ = estimation::ForwardTable::load_or_build(set, grid, cache_dir, &rebuilt_, threads);
  }
}

void RelitTable::rgb(const estimation::SkinParameters& p, Eigen::Vector3d* out) const {
  constexpr std::size_t kInline = 8;  // illuminants without a heap buffer
  double inline_values[3 * kInline];
  std::unique_ptr<double[]> heap;
  double* values = inline_values;
  if (illuminants_ > kInline) {
    heap = std::make_unique<double[]>(3 * illuminants_);
    values = heap.get();
  }
  table_->predict(table_->to_grid(p), values);
  for (std::size_t i = 0; i < illuminants_; ++i) out[i] = Eigen::Vector3d(values[3 * i], values[3 * i + 1], values[3 * i + 2]);
}

}  // namespace chromo::maps
