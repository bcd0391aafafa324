#include "chromo/maps/reconstruction.hpp"

#include <random>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::maps {

DeltaEStats delta_e_stats(std::vector<double> v) {
  DeltaEStats s;
  s.pixels = v.size();
  if (v.empty()) return s;
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / v.size();
  // The order statistics a full sort would give, by selection (linear time):
  // the median, then the p95 and the max above it.
  auto rank = [&](double q) { return std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5)); };
  const std::size_t median = rank(0.5), p95 = rank(0.95);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(median), v.end());
  s.median = v[median];
  std::nth_element(v.begin() + static_cast<std::ptrdiff_t>(median), v.begin() + static_cast<std::ptrdiff_t>(p95), v.end());
  s.p95 = v[p95];
  s.max = *std::max_element(v.begin() + static_cast<std::ptrdiff_t>(p95), v.end());
  return s;
}

namespace {
std::vector<spectral::Spectrum> albedos(std::span<const estimation::SkinParameters> parameters, int threads) {
  static const estimation::SkinModel model;
  std::vector<spectral::Spectrum> out(parameters.size());
  model.albedo_batch(parameters, out, threads);
  return out;
}
}  // namespace

std::vector<spectral::Lab> relit_lab(std::span<const estimation::SkinParameters> parameters, const spectral::Spectrum& illuminant,
                                     int threads) {
  const std::vector<spectral::Spectrum> a = albedos(parameters, threads);
  const spectral::Xyz white = spectral::white_point(illuminant);
  std::vector<spectral::Lab> out(a.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    out[i] = spectral::lab_from_xyz(spectral::xyz_of_reflectance(a[i], illuminant), white);
  return out;
}

std::vector<double> relit_delta_e94(std::span<const estimation::SkinParameters> truth, std::span<const estimation::SkinParameters> estimate,
                                    const spectral::Spectrum& illuminant, int threads) {
  if (truth.size() != estimate.size()) throw std::invalid_argument("relit_delta_e94: sizes differ");
  const auto a = relit_lab(truth, illuminant, threads), b = relit_lab(estimate, illuminant, threads);
  std::vector<double> out(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) out[i] = spectral::delta_e94(a[i], b[i]);
  return out;
}

std::vector<Eigen::Vector3d> relit_camera_rgb(std::span<const estimation::SkinParameters> parameters,
                                              const spectral::CameraSensitivity& camera,
                                              const spectral::Spectrum& illuminant, int threads) {
  const std::vector<spectral::Spectrum> a = albedos(parameters, threads);
  const spectral::CameraWeights w = spectral::camera_weights(camera, illuminant);
  std::vector<Eigen::Vector3d> out(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) out[i] = w * a[i].values().matrix();
  return out;
}

Eigen::Matrix3d camera_to_xyz_matrix(const spectral::CameraSensitivity& camera, const spectral::Spectrum& illuminant) {
  const spectral::Table chart = spectral::parse_table(spectral::data::embedded_file("colorchecker_reflectance_ohta.csv"),
                                                      "colorchecker_reflectance_ohta.csv");
  const spectral::CameraWeights w = spectral::camera_weights(camera, illuminant);
  const int patches = static_cast<int>(chart.column_names.size()) - 1;
  Eigen::MatrixXd rgb(patches, 3), xyz(patches, 3);
  for (int p = 0; p < patches; ++p) {
    const spectral::Spectrum r = spectral::resample_column(chart, chart.column_names[p + 1]);
    rgb.row(p) = (w * r.values().matrix()).transpose();
    const spectral::Xyz x = spectral::xyz_of_reflectance(r, illuminant);
    xyz.row(p) << x.X, x.Y, x.Z;
  }
  // xyz ≈ rgb · Mᵀ
  // Normal equations (3×3): lazy products avoid GCC 12's false AVX-512 GEMM warning.
  const Eigen::Matrix3d rtr = rgb.transpose().lazyProduct(rgb);
  const Eigen::Matrix3d rtx = rgb.transpose().lazyProduct(xyz);
  return rtr.ldlt().solve(rtx).transpose();
}

std::vector<spectral::Lab> photo_lab_map(std::span<const Eigen::Vector3d> rgb, const spectral::CameraSensitivity& camera,
                                         const spectral::Spectrum& illuminant) {
  const Eigen::Matrix3d m = camera_to_xyz_matrix(camera, illuminant);
  const spectral::Xyz white = spectral::white_point(illuminant);
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::vector<spectral::Lab> lab(rgb.size(), spectral::Lab{kNaN, kNaN, kNaN});
  const auto count = static_cast<std::ptrdiff_t>(rgb.size());
  // Pixels are independent: on every core for a large image.
#pragma omp parallel for schedule(static) if (count > 65536)
  for (std::ptrdiff_t k = 0; k < count; ++k) {
    const auto i = static_cast<std::size_t>(k);
    if (!rgb[i].allFinite()) continue;
    const Eigen::Vector3d x = m * rgb[i];
    lab[i] = spectral::lab_from_xyz({x[0], x[1], x[2]}, white);
  }
  return lab;
}

std::vector<double> delta_e94_map(std::span<const spectral::Lab> reference, std::span<const spectral::Lab> sample) {
  if (reference.size() != sample.size()) throw std::invalid_argument("delta_e94_map: image sizes differ");
  std::vector<double> de(reference.size(), std::numeric_limits<double>::quiet_NaN());
  const auto count = static_cast<std::ptrdiff_t>(reference.size());
#pragma omp parallel for schedule(static) if (count > 65536)
  for (std::ptrdiff_t k = 0; k < count; ++k) {
    const auto i = static_cast<std::size_t>(k);
    if (!std::isnan(reference[i].L) && !std::isnan(sample[i].L)) de[i] = spectral::delta_e94(reference[i], sample[i]);
  }
  return de;
}

std::vector<double> photo_delta_e94_map(std::span<const Eigen::Vector3d> photograph,
                                        std::span<const Eigen::Vector3d> reconstruction,
                                        const spectral::CameraSensitivity& camera, const spectral::Spectrum& illuminant) {
  if (photograph.size() != reconstruction.size()) throw std::invalid_argument("photo_delta_e94: image sizes differ");
  return delta_e94_map(photo_lab_map(photograph, camera, illuminant), photo_lab_map(reconstruction, camera, illuminant));
}

namespace {
// The photograph with one draw of its noise model per pixel and channel, in
// pixel order (serial: the same seed gives the same draw on any core count).
std::vector<Eigen::Vector3d> noisy_copy(std::span<const Eigen::Vector3d> photograph,
                                        const std::array<estimation::ChannelNoise, 3>& noise, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::normal_distribution<double> normal;
  std::vector<Eigen::Vector3d> noisy(photograph.begin(), photograph.end());
  for (auto& rgb : noisy)
    for (int c = 0; c < 3; ++c) rgb[c] += std::sqrt(noise[static_cast<std::size_t>(c)].variance(rgb[c])) * normal(random);
  return noisy;
}
}  // namespace

std::vector<double> photograph_noise_delta_e94_map(std::span<const Eigen::Vector3d> photograph,
                                                   const std::array<estimation::ChannelNoise, 3>& noise,
                                                   const spectral::CameraSensitivity& camera,
                                                   const spectral::Spectrum& illuminant, std::uint64_t seed) {
  return photograph_noise_delta_e94_map(photograph, photo_lab_map(photograph, camera, illuminant), noise, camera,
                                        illuminant, seed);
}

std::vector<double> photograph_noise_delta_e94_map(std::span<const Eigen::Vector3d> photograph,
                                                   std::span<const spectral::Lab> photograph_lab,
                                                   const std::array<estimation::ChannelNoise, 3>& noise,
                                                   const spectral::CameraSensitivity& camera,
                                                   const spectral::Spectrum& illuminant, std::uint64_t seed) {
  if (photograph_lab.size() != photograph.size())
    throw std::invalid_argument("photograph_noise_delta_e94_map: the photograph's Lab is not the photograph's size");
  return delta_e94_map(photograph_lab, photo_lab_map(noisy_copy(photograph, noise, seed), camera, illuminant));
}

DeltaEStats photo_delta_e94(std::span<const Eigen::Vector3d> photograph, std::span<const Eigen::Vector3d> reconstruction,
                            const spectral::CameraSensitivity& camera, const spectral::Spectrum& illuminant,
                            std::span<const bool> include) {
  if (!include.empty() && include.size() != photograph.size())
    throw std::invalid_argument("photo_delta_e94: image sizes differ");
  const std::vector<double> map = photo_delta_e94_map(photograph, reconstruction, camera, illuminant);
  std::vector<double> de;
  for (std::size_t i = 0; i < map.size(); ++i)
    if ((include.empty() || include[i]) && std::isfinite(map[i])) de.push_back(map[i]);
  return delta_e_stats(std::move(de));
}

}  // namespace chromo::maps
