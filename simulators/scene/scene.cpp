#include "chromo/simulators/scene/scene.hpp"

#include <stdexcept>

namespace chromo::simulators {

const char* region_name(SceneRegion region) {
  switch (region) {
    case SceneRegion::kSkin: return "skin";
    case SceneRegion::kVein: return "vein";
    case SceneRegion::kTattoo: return "tattoo";
    case SceneRegion::kMarker: return "marker";
    case SceneRegion::kHair: return "hair";
    case SceneRegion::kSpecular: return "specular";
    case SceneRegion::kWhiteTarget: return "white_target";
  }
  return "unknown";
}

spectral::Spectrum white_target_reflectance() { return spectral::Spectrum::constant(kWhiteTargetReflectance); }

Scene::Scene(int width, int height)
    : width_(width),
      height_(height),
      albedo_(static_cast<std::size_t>(width) * height * spectral::kGridSize, 0.0f),
      regions_(height, width, CV_8U, cv::Scalar(0)),
      cm_(height, width, CV_32F, cv::Scalar(0)),
      ch_(height, width, CV_32F, cv::Scalar(0)),
      bm_(height, width, CV_32F, cv::Scalar(0)),
      che_(height, width, CV_32F, cv::Scalar(0)) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("Scene: width and height must be positive");
}

spectral::Spectrum Scene::albedo_at(int x, int y) const {
  spectral::Spectrum s;
  const float* p = &albedo_[(static_cast<std::size_t>(y) * width_ + x) * spectral::kGridSize];
  for (int i = 0; i < spectral::kGridSize; ++i) s[i] = p[i];
  return s;
}

void Scene::set_albedo(int x, int y, const spectral::Spectrum& albedo) {
  float* p = &albedo_[(static_cast<std::size_t>(y) * width_ + x) * spectral::kGridSize];
  for (int i = 0; i < spectral::kGridSize; ++i) p[i] = static_cast<float>(albedo[i]);
}

cv::Mat Scene::render(const Eigen::Matrix<double, Eigen::Dynamic, spectral::kGridSize>& weights) const {
  const auto channels = static_cast<int>(weights.rows());
  if (channels < 1 || channels > 4) throw std::invalid_argument("Scene::render: 1-4 weight rows");
  // Plain loops (Eigen's float GEMM trips a GCC 12 -Wmaybe-uninitialized false positive under AVX-512).
  std::vector<float> w(static_cast<std::size_t>(channels) * spectral::kGridSize);
  for (int c = 0; c < channels; ++c)
    for (int i = 0; i < spectral::kGridSize; ++i) w[c * spectral::kGridSize + i] = static_cast<float>(weights(c, i));
  cv::Mat out(height_, width_, CV_32FC(channels));
  const auto pixels = static_cast<std::ptrdiff_t>(width_) * height_;
  float* result = out.ptr<float>();
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t p = 0; p < pixels; ++p) {
    const float* a = &albedo_[static_cast<std::size_t>(p) * spectral::kGridSize];
    for (int c = 0; c < channels; ++c) {
      const float* wc = &w[static_cast<std::size_t>(c) * spectral::kGridSize];
      float sum = 0;
      for (int i = 0; i < spectral::kGridSize; ++i) sum += wc[i] * a[i];
      result[p * channels + c] = sum;
    }
  }
  return out;
}

}  // namespace chromo::simulators
