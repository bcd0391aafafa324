#include "chromo/simulators/scene/subsurface_spread.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "chromo/spectral/grid.hpp"

namespace chromo::simulators {

double SubsurfaceSpread::sigma_px(double wavelength_nm) const {
  return sigma_blue_px + (sigma_red_px - sigma_blue_px) * std::clamp((wavelength_nm - 450.0) / 250.0, 0.0, 1.0);
}

bool SubsurfaceSpread::IsValid(std::string* error) const {
  if (!(sigma_blue_px > 0 && sigma_blue_px <= sigma_red_px && sigma_red_px <= 64)) {
    if (error != nullptr) *error = "subsurface: 0 < sigma_blue_px <= sigma_red_px <= 64";
    return false;
  }
  return true;
}

void apply_subsurface_spread(Scene& scene, const SubsurfaceSpread& spread, const cv::Mat& skin_side,
                             const std::function<double(int, int)>& surface) {
  if (std::string error; !spread.IsValid(&error)) throw std::invalid_argument(error);
  const int w = scene.width(), h = scene.height();
  if (skin_side.rows != h || skin_side.cols != w || skin_side.type() != CV_8U)
    throw std::invalid_argument("subsurface: the skin-side mask must be CV_8U of the scene's size");
  cv::Mat weight, reflection(h, w, CV_32F);
  skin_side.convertTo(weight, CV_32F, 1.0 / 255.0);
  cv::threshold(weight, weight, 0, 1, cv::THRESH_BINARY);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) reflection.at<float>(y, x) = weight.at<float>(y, x) > 0 ? static_cast<float>(surface(x, y)) : 0.f;
  const float* albedo = scene.albedo_data();
  std::vector<cv::Mat> bands(spectral::kGridSize);
  for (int l = 0; l < spectral::kGridSize; ++l) {
    // The diffuse light of the skin side (albedo minus its surface reflection), weighted by the mask.
    cv::Mat band(h, w, CV_32F);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        band.at<float>(y, x) = (albedo[i * spectral::kGridSize + l] - reflection.at<float>(y, x)) * weight.at<float>(y, x);
      }
    const double sigma = spread.sigma_px(spectral::grid_wavelength_nm(l));
    cv::Mat blurred, norm;
    cv::GaussianBlur(band, blurred, cv::Size(), sigma, sigma, cv::BORDER_REFLECT);
    cv::GaussianBlur(weight, norm, cv::Size(), sigma, sigma, cv::BORDER_REFLECT);
    bands[l] = blurred / cv::max(norm, 1e-6);  // normalised over the skin side
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (weight.at<float>(y, x) == 0) continue;
      spectral::Spectrum a;
      for (int l = 0; l < spectral::kGridSize; ++l) a[l] = bands[l].at<float>(y, x) + reflection.at<float>(y, x);
      scene.set_albedo(x, y, a);
    }
}

}  // namespace chromo::simulators
