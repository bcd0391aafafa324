#include "chromo/simulators/camera/camera_model.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace chromo::simulators {

bool CameraModelOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!(quantum_scale_e_per_us > 0)) return fail("quantum_scale_e_per_us must be > 0");
  if (!(full_well_e > 0)) return fail("full_well_e must be > 0");
  if (!(read_noise_e >= 0)) return fail("read_noise_e must be >= 0");
  if (!(gain_e_per_dn > 0)) return fail("gain_e_per_dn must be > 0");
  if (adc_bits < 8 || adc_bits > 16) return fail("adc_bits must be 8-16");
  if (!(black_level_dn >= 0)) return fail("black_level_dn must be >= 0");
  if (!(sensitivity.rgb[1].integral() > 0)) return fail("the green sensitivity is zero");
  return true;
}

CameraModel::CameraModel(CameraModelOptions options) : options_(std::move(options)) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("CameraModelOptions: " + error);
  green_norm_ = options_.sensitivity.rgb[1].integral();
}

Eigen::Matrix<double, 3, spectral::kGridSize> CameraModel::weights(const spectral::Spectrum& irradiance) const {
  Eigen::Matrix<double, 3, spectral::kGridSize> w;
  for (int c = 0; c < 3; ++c)
    w.row(c) = (options_.sensitivity.rgb[c].values() * irradiance.values() * spectral::kGridStepNm / green_norm_)
                   .matrix()
                   .transpose();
  return w;
}

double CameraModel::expected_dn(double response, double exposure_us, double gain_db) const {
  const double electrons = std::min(options_.quantum_scale_e_per_us * exposure_us * response, options_.full_well_e);
  const double e_per_dn = options_.gain_e_per_dn / std::pow(10.0, gain_db / 20.0);
  return std::clamp(options_.black_level_dn + electrons / e_per_dn, 0.0, static_cast<double>(max_dn()));
}

double CameraModel::noise_sigma_dn(double response, double exposure_us, double gain_db) const {
  const double electrons = std::min(options_.quantum_scale_e_per_us * exposure_us * response, options_.full_well_e);
  const double e_per_dn = options_.gain_e_per_dn / std::pow(10.0, gain_db / 20.0);
  const double sigma_e = std::sqrt(std::max(electrons, 0.0) + options_.read_noise_e * options_.read_noise_e);
  return std::sqrt(std::pow(sigma_e / e_per_dn, 2) + 1.0 / 12.0);  // + quantisation
}

namespace {

// Reads out `response_rgb` into `out` (same size, 1 or 3 channels of T),
// sample by sample: read(response) for every sensor site of the layout.
template <typename T, typename Read>
void read_out(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y, cv::Mat& out, Read read) {
  for (int y = 0; y < response_rgb.rows; ++y) {
    const auto* in = response_rgb.ptr<cv::Vec3f>(y);
    if (layout == SensorLayout::kThreeChannel) {
      auto* o = out.ptr<cv::Vec<T, 3>>(y);
      for (int x = 0; x < response_rgb.cols; ++x)
        for (int c = 0; c < 3; ++c) o[x][c] = read(in[x][c]);
    } else {
      auto* o = out.ptr<T>(y);
      for (int x = 0; x < response_rgb.cols; ++x) {
        double r;
        if (layout == SensorLayout::kMono) {
          r = (in[x][0] + in[x][1] + in[x][2]) / 3.0;
        } else {
          const int sx = (x + phase_x) & 1, sy = (y + phase_y) & 1;
          r = (sx == 0 && sy == 0) ? in[x][0] : (sx == 1 && sy == 1) ? in[x][2] : in[x][1];
        }
        o[x] = read(r);
      }
    }
  }
}

}  // namespace

cv::Mat CameraModel::expose(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y,
                            double exposure_us, double gain_db, std::uint64_t frame_index) const {
  if (response_rgb.type() != CV_32FC3) throw std::invalid_argument("CameraModel::expose: response must be CV_32FC3");
  std::mt19937_64 rng(options_.seed * 0x9E3779B97F4A7C15ull + frame_index);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double e_scale = options_.quantum_scale_e_per_us * exposure_us;
  const double e_per_dn = options_.gain_e_per_dn / std::pow(10.0, gain_db / 20.0);
  const double top = max_dn();
  auto read = [&](double response) -> std::uint16_t {
    const double mean_e = std::max(e_scale * response, 0.0);
    double e;
    if (mean_e < 30) e = static_cast<double>(std::poisson_distribution<long>(mean_e)(rng));
    else e = mean_e + std::sqrt(mean_e) * normal(rng);
    e = std::clamp(e, 0.0, options_.full_well_e) + options_.read_noise_e * normal(rng);
    return static_cast<std::uint16_t>(std::clamp(std::round(options_.black_level_dn + e / e_per_dn), 0.0, top));
  };
  cv::Mat out(response_rgb.rows, response_rgb.cols, layout == SensorLayout::kThreeChannel ? CV_16UC3 : CV_16U);
  read_out<std::uint16_t>(response_rgb, layout, phase_x, phase_y, out, read);
  return out;
}

cv::Mat CameraModel::expected(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y,
                              double exposure_us, double gain_db) const {
  if (response_rgb.type() != CV_32FC3) throw std::invalid_argument("CameraModel::expected: response must be CV_32FC3");
  cv::Mat out(response_rgb.rows, response_rgb.cols, layout == SensorLayout::kThreeChannel ? CV_32FC3 : CV_32F);
  read_out<float>(response_rgb, layout, phase_x, phase_y, out, [&](double response) {
    return static_cast<float>(expected_dn(response, exposure_us, gain_db));
  });
  return out;
}

}  // namespace chromo::simulators
