#include "chromo/maps/relight.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/grid.hpp"
#include "chromo/spectral/srgb.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::maps {

spectral::Spectrum planckian_illuminant(double cct_K) {
  constexpr double c2 = 1.4387769e7;  // second radiation constant, nm·K
  auto planck = [&](double nm) { return std::pow(nm, -5.0) / std::expm1(c2 / (nm * cct_K)); };
  spectral::Spectrum out;
  for (int i = 0; i < spectral::kGridSize; ++i) out[i] = planck(spectral::grid_wavelength_nm(i));
  return out * (100.0 / planck(560.0));
}

NamedSpectrum resolve_illuminant(const std::string& text) {
  if (text.empty()) throw std::invalid_argument("illuminant: empty (give W57, W40, W27, R, G, B, D65, D50, A, a CCT like 4000K, or a CSV file)");
  if (auto led = spectral::parse_led_type(text)) return {text, spectral::led_spectrum(*led)};
  std::string lower = text;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  if (lower == "d65") return {"D65", spectral::illuminant_d65()};
  if (lower == "d50") return {"D50", spectral::illuminant_d50()};
  if (lower == "a") return {"A", spectral::illuminant_a()};
  if (lower.size() > 1 && lower.back() == 'k' &&
      std::all_of(lower.begin(), lower.end() - 1, [](char c) { return std::isdigit(static_cast<unsigned char>(c)) || c == '.'; })) {
    char* end = nullptr;
    const std::string digits = lower.substr(0, lower.size() - 1);
    const double cct = std::strtod(digits.c_str(), &end);
    if (end != digits.c_str() + digits.size() || !(cct >= 1000 && cct <= 25000))
      throw std::invalid_argument("illuminant \"" + text + "\": colour temperature must be 1000-25000 K");
    return {lower.substr(0, lower.size() - 1) + "K", cct < 5000 ? planckian_illuminant(cct) : spectral::daylight_illuminant(cct)};
  }
  try {
    spectral::Spectrum s = spectral::read_spectrum_file(text);
    if (!(s.max() > 0)) throw std::invalid_argument("illuminant \"" + text + "\": the spectrum has no power");
    return {std::filesystem::path(text).stem().string(), s};
  } catch (const spectral::DataError& e) {
    throw std::invalid_argument("illuminant \"" + text +
                                "\": not W57, W40, W27, R, G, B, D65, D50, A or a CCT like 4000K, and not a readable "
                                "spectrum file (" + e.what() + ")");
  }
}

spectral::CameraWeights linear_srgb_weights(const spectral::Spectrum& illuminant) {
  // The pipeline is linear in the albedo: apply it to each wavelength's impulse.
  const spectral::Xyz white = spectral::white_point(illuminant);
  spectral::CameraWeights w;
  for (int k = 0; k < spectral::kGridSize; ++k) {
    spectral::Spectrum impulse;
    impulse[k] = 1.0;
    const spectral::Rgb rgb = spectral::linear_srgb_from_xyz(spectral::xyz_of_reflectance(impulse, illuminant), white);
    w(0, k) = rgb.r, w(1, k) = rgb.g, w(2, k) = rgb.b;
  }
  return w;
}

estimation::SkinParameters parameters_at(const ParameterMaps& maps, std::size_t i) {
  return {maps.cm[i], maps.ch[i], maps.bm[i], maps.che[i]};
}

bool is_relightable(const ParameterMaps& maps, std::size_t i) {
  const float flag = maps.flags.empty() ? 0.0f : maps.flags[i];
  if (flag == 1.0f || flag == 2.0f || flag == 3.0f) return false;
  return std::isfinite(maps.cm[i]) && std::isfinite(maps.ch[i]) && std::isfinite(maps.bm[i]) &&
         std::isfinite(maps.che[i]) && maps.cm[i] > 0 && maps.ch[i] > 0;
}

RelitImage relight(const ParameterMaps& maps, const spectral::CameraWeights& weights, int threads) {
  static const estimation::SkinModel model;
  RelitImage out;
  out.width = maps.width, out.height = maps.height;
  const std::size_t pixels = static_cast<std::size_t>(maps.width) * maps.height;
  out.rgb.assign(3 * pixels, 0.0f);
  out.valid.assign(pixels, 0);
  constexpr std::size_t kBlock = 16384;  // 10 MB of spectra per block
  std::vector<estimation::SkinParameters> block;
  std::vector<std::size_t> where;
  std::vector<spectral::Spectrum> albedo;
  // The relit layer "model + discrepancy" (discrepancy_layer.hpp): B c seen through the weights.
  const DiscrepancyLayer* layer = maps.discrepancy ? &*maps.discrepancy : nullptr;
  const Eigen::Matrix<double, 3, Eigen::Dynamic> seen = layer ? projected_basis(layer->basis, weights)
                                                               : Eigen::Matrix<double, 3, Eigen::Dynamic>(3, 0);
  Eigen::VectorXd c(seen.cols());
  for (std::size_t start = 0; start < pixels; start += kBlock) {
    block.clear(), where.clear();
    for (std::size_t i = start; i < std::min(pixels, start + kBlock); ++i)
      if (is_relightable(maps, i)) block.push_back(parameters_at(maps, i)), where.push_back(i);
    albedo.resize(block.size());
    model.albedo_batch(block, albedo, threads);
    for (std::size_t k = 0; k < block.size(); ++k) {
      Eigen::Vector3d rgb = weights * albedo[k].values().matrix();
      if (layer) {
        layer->at(where[k], c.data());
        rgb += seen * c;
      }
      for (int c = 0; c < 3; ++c) out.rgb[3 * where[k] + c] = static_cast<float>(rgb[c]);
      out.valid[where[k]] = 1;
    }
  }
  return out;
}

}  // namespace chromo::maps
