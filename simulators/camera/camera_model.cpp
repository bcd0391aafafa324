#include "chromo/simulators/camera/camera_model.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "chromo/simulators/camera/readout_random.hpp"

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
  if (!(nonlinearity_at_full_well >= 0 && nonlinearity_at_full_well <= 0.5))
    return fail("nonlinearity_at_full_well must be in [0, 0.5]");
  if (readout_threads < 0) return fail("readout_threads must be >= 0 (0 = OpenMP's default)");
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

double CameraModel::compressed_e(double electrons) const {
  return electrons * (1.0 - options_.nonlinearity_at_full_well * electrons / options_.full_well_e);
}

double CameraModel::expected_dn(double response, double exposure_us, double gain_db) const {
  const double electrons =
      compressed_e(std::min(options_.quantum_scale_e_per_us * exposure_us * response, options_.full_well_e));
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

// Reads rows [row_begin, row_end) of `response_rgb` out into `out` (same
// size, 1 or 3 channels of T), sample by sample in row-major order:
// read(response) for every sensor site of the layout.
template <typename T, typename Read>
void read_out_rows(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y, int row_begin,
                   int row_end, cv::Mat& out, Read&& read) {
  for (int y = row_begin; y < row_end; ++y) {
    const auto* in = response_rgb.ptr<cv::Vec3f>(y);
    if (layout == SensorLayout::kThreeChannel) {
      auto* o = out.ptr<cv::Vec<T, 3>>(y);
      for (int x = 0; x < response_rgb.cols; ++x)
        for (int c = 0; c < 3; ++c) o[x][c] = read(in[x][c]);
    } else if (layout == SensorLayout::kMono) {
      auto* o = out.ptr<T>(y);
      for (int x = 0; x < response_rgb.cols; ++x) o[x] = read((in[x][0] + in[x][1] + in[x][2]) / 3.0);
    } else {  // RGGB: R at even row and column of the sensor, B at odd ones, G between
      auto* o = out.ptr<T>(y);
      const bool red_row = ((y + phase_y) & 1) == 0;
      const int channel_at_even_x = red_row ? 0 : 1, channel_at_odd_x = red_row ? 1 : 2;
      for (int x = 0; x < response_rgb.cols; ++x)
        o[x] = read(static_cast<double>(in[x][((x + phase_x) & 1) == 0 ? channel_at_even_x : channel_at_odd_x]));
    }
  }
}

template <typename T, typename Read>
void read_out(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y, cv::Mat& out, Read&& read) {
  read_out_rows<T>(response_rgb, layout, phase_x, phase_y, 0, response_rgb.rows, out, read);
}

cv::Mat readout_frame(const cv::Mat& response_rgb, SensorLayout layout, int depth) {
  return cv::Mat(response_rgb.rows, response_rgb.cols, CV_MAKETYPE(depth, layout == SensorLayout::kThreeChannel ? 3 : 1));
}

// A frame's seed: its noise is a function of (camera seed, frame index) only.
std::uint64_t frame_seed(std::uint64_t camera_seed, std::uint64_t frame_index) {
  return camera_seed * 0x9E3779B97F4A7C15ull + frame_index;
}

}  // namespace

CameraModel::Readout CameraModel::readout(double exposure_us, double gain_db) const {
  Readout r;
  r.electrons_per_response = options_.quantum_scale_e_per_us * exposure_us;
  r.e_per_dn = options_.gain_e_per_dn / std::pow(10.0, gain_db / 20.0);
  r.max_dn = max_dn();
  return r;
}

cv::Mat CameraModel::expose(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y,
                            double exposure_us, double gain_db, std::uint64_t frame_index) const {
  if (response_rgb.type() != CV_32FC3) throw std::invalid_argument("CameraModel::expose: response must be CV_32FC3");
  const Readout r = readout(exposure_us, gain_db);
  const double dn_per_e = 1.0 / r.e_per_dn, black = options_.black_level_dn, full_well = options_.full_well_e;
  const double read_noise = options_.read_noise_e;
  const std::uint64_t seed = frame_seed(options_.seed, frame_index);
  const readout_random::ZigguratNormal normal;
  cv::Mat out = readout_frame(response_rgb, layout, CV_16U);
  const int rows = response_rgb.rows;
  const int bands = (rows + readout_random::kBandRows - 1) / readout_random::kBandRows;
#ifdef _OPENMP
  const int threads = options_.readout_threads > 0 ? options_.readout_threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (bands > 1 && threads > 1)
#endif
  for (int band = 0; band < bands; ++band) {
    readout_random::Xoshiro256Plus rng = readout_random::band_stream(seed, static_cast<std::uint64_t>(band));
    auto read = [&](double response) -> std::uint16_t {
      const double mean_e = std::max(r.electrons_per_response * response, 0.0);
      double e;
      if (mean_e == 0) e = 0;  // Poisson(0): no light, no draw (dark captures)
      else if (mean_e < kExactPoissonBelowElectrons) e = static_cast<double>(readout_random::poisson_by_inversion(mean_e, rng));
      else e = mean_e + std::sqrt(mean_e) * normal(rng);
      e = compressed_e(std::clamp(e, 0.0, full_well)) + read_noise * normal(rng);
      return static_cast<std::uint16_t>(std::floor(std::clamp(black + e * dn_per_e, 0.0, r.max_dn) + 0.5));
    };
    const int row_begin = band * readout_random::kBandRows;
    read_out_rows<std::uint16_t>(response_rgb, layout, phase_x, phase_y, row_begin,
                                 std::min(rows, row_begin + readout_random::kBandRows), out, read);
  }
  return out;
}

cv::Mat CameraModel::expose_single_stream(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y,
                                          double exposure_us, double gain_db, std::uint64_t frame_index) const {
  if (response_rgb.type() != CV_32FC3)
    throw std::invalid_argument("CameraModel::expose_single_stream: response must be CV_32FC3");
  std::mt19937_64 rng(frame_seed(options_.seed, frame_index));
  std::normal_distribution<double> normal(0.0, 1.0);
  const Readout r = readout(exposure_us, gain_db);
  auto read = [&](double response) -> std::uint16_t {
    const double mean_e = std::max(r.electrons_per_response * response, 0.0);
    double e;
    if (mean_e < kExactPoissonBelowElectrons) e = static_cast<double>(std::poisson_distribution<long>(mean_e)(rng));
    else e = mean_e + std::sqrt(mean_e) * normal(rng);
    e = compressed_e(std::clamp(e, 0.0, options_.full_well_e)) + options_.read_noise_e * normal(rng);
    return static_cast<std::uint16_t>(std::clamp(std::round(options_.black_level_dn + e / r.e_per_dn), 0.0, r.max_dn));
  };
  cv::Mat out = readout_frame(response_rgb, layout, CV_16U);
  read_out<std::uint16_t>(response_rgb, layout, phase_x, phase_y, out, read);
  return out;
}

cv::Mat CameraModel::expected(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y,
                              double exposure_us, double gain_db) const {
  if (response_rgb.type() != CV_32FC3) throw std::invalid_argument("CameraModel::expected: response must be CV_32FC3");
  cv::Mat out = readout_frame(response_rgb, layout, CV_32F);
  read_out<float>(response_rgb, layout, phase_x, phase_y, out, [&](double response) {
    return static_cast<float>(expected_dn(response, exposure_us, gain_db));
  });
  return out;
}

}  // namespace chromo::simulators
