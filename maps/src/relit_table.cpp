#include "chromo/maps/relit_table.hpp"

#include <omp.h>

#include <stdexcept>
#include <string>

namespace chromo::maps {

namespace {

// Three channels (camera R, G, B) per illuminant.
estimation::MeasurementSet relit_set(const spectral::CameraSensitivity& camera, std::span<const spectral::Spectrum> illuminants) {
  if (illuminants.empty()) throw std::invalid_argument("relit table: no illuminant");
  estimation::MeasurementSet set;
  set.camera = camera;
  for (std::size_t i = 0; i < illuminants.size(); ++i)
    for (int c = 0; c < 3; ++c)
      set.channels.push_back({"illuminant" + std::to_string(i) + "." + "RGB"[c], illuminants[i], c, {}});
  return set;
}

}  // namespace

std::uint64_t RelitTable::cache_key(const spectral::CameraSensitivity& camera,
                                    std::span<const spectral::Spectrum> illuminants, const estimation::TableGrid& grid) {
  return estimation::ForwardTable::cache_key(relit_set(camera, illuminants), grid);
}

RelitTable::RelitTable(const spectral::CameraSensitivity& camera, std::span<const spectral::Spectrum> illuminants,
                       const estimation::TableGrid& grid, const std::filesystem::path& cache_dir, int threads)
    : illuminants_(illuminants.size()) {
  const estimation::MeasurementSet set = relit_set(camera, illuminants);
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

std::vector<std::vector<Eigen::Vector3d>> RelitTable::rgb(std::span<const estimation::SkinParameters> parameters,
                                                          int threads) const {
  std::vector<std::vector<Eigen::Vector3d>> out(illuminants_, std::vector<Eigen::Vector3d>(parameters.size()));
  const auto count = static_cast<std::ptrdiff_t>(parameters.size());
#pragma omp parallel num_threads(threads > 0 ? threads : omp_get_max_threads())
  {
    std::vector<Eigen::Vector3d> one(illuminants_);
#pragma omp for schedule(static)
    for (std::ptrdiff_t k = 0; k < count; ++k) {
      rgb(parameters[static_cast<std::size_t>(k)], one.data());
      for (std::size_t i = 0; i < illuminants_; ++i) out[i][static_cast<std::size_t>(k)] = one[i];
    }
  }
  return out;
}

}  // namespace chromo::maps
