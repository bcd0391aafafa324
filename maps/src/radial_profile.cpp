#include "chromo/maps/radial_profile.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "chromo/estimation/layer_optics.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/srgb.hpp"

namespace chromo::maps {

using spectral::kGridSize;
using spectral::Spectrum;

bool RadialProfileOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!(min_radius_mm > 0.0)) return fail("min_radius_mm must be > 0");
  if (!(max_radius_mm > min_radius_mm)) return fail("max_radius_mm must exceed min_radius_mm");
  if (radius_count < 8 || radius_count > 100000) return fail("radius_count must be in 8-100000");
  if (!(frequency_step_per_mm > 0.0)) return fail("frequency_step_per_mm must be > 0");
  if (frequency_step_per_mm * max_radius_mm > 0.2)
    return fail("frequency_step_per_mm × max_radius_mm must be ≤ 0.2 (the discrete inversion's plane-integral error "
                "grows as their product squared: 0.5 gives 0.5%, 0.2 under 0.1%)");
  if (!(max_frequency_per_mm > 10.0 * frequency_step_per_mm)) return fail("max_frequency_per_mm too small");
  if (max_frequency_per_mm / frequency_step_per_mm > 2e6) return fail("frequency grid larger than 2e6 samples");
  return true;
}

namespace {

struct LayerCoefficients {
  double alpha, sigma_tr, l, zb0, period;  // epidermis slab geometry (MODEL.md)
};

// One pole's exitance per unit area at radius r: α'·z·(1+σρ)e^(-σρ)/(4πρ³).
double pole_exitance(double alpha, double sigma_tr, double z, double r) {
  const double rho = std::sqrt(r * r + z * z);
  return alpha * z * (1.0 + sigma_tr * rho) * std::exp(-sigma_tr * rho) / (4.0 * std::numbers::pi * rho * rho * rho);
}

}  // namespace

RadialProfileModel::RadialProfileModel(const estimation::SkinModel& model, const Spectrum& illuminant, RadialProfileOptions options)
    : model_(model), options_(options), skin_air_a_(estimation::boundary_coefficient(estimation::kSkinRefractiveIndex)) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("RadialProfileOptions: " + error);
  const double log_step = std::log(options_.max_radius_mm / options_.min_radius_mm) / (options_.radius_count - 1);
  for (int i = 0; i < options_.radius_count; ++i) radii_mm_.push_back(options_.min_radius_mm * std::exp(log_step * i));
  const int k_count = static_cast<int>(std::ceil(options_.max_frequency_per_mm / options_.frequency_step_per_mm)) + 1;
  for (int j = 0; j < k_count; ++j) frequencies_per_mm_.push_back(j * options_.frequency_step_per_mm);
  k_squared_ = Eigen::Map<const Eigen::ArrayXd>(frequencies_per_mm_.data(), k_count).square();

  hankel_kernel_.resize(options_.radius_count, k_count);
  const double dk = options_.frequency_step_per_mm;
  for (int i = 0; i < options_.radius_count; ++i) {
    for (int j = 0; j < k_count; ++j) {
      const double k = frequencies_per_mm_[j];
      const double trapezoid = (j == 0 || j == k_count - 1) ? 0.5 : 1.0;
      hankel_kernel_(i, j) = trapezoid * dk * k * std::cyl_bessel_j(0.0, k * radii_mm_[i]) / (2.0 * std::numbers::pi);
    }
  }

  // Linear sRGB of an albedo is linear in it: build the weights from the
  // response to each grid bin alone.
  const spectral::Xyz white = spectral::white_point(illuminant);
  for (int b = 0; b < kGridSize; ++b) {
    Spectrum spike;
    spike[b] = 1.0;
    const spectral::Rgb rgb = spectral::linear_srgb_from_xyz(spectral::xyz_of_reflectance(spike, illuminant), white);
    rgb_weights_.col(b) << rgb.r, rgb.g, rgb.b;
  }
}

RadialProfile RadialProfileModel::profile(const estimation::SkinParameters& p) const {
  const estimation::ChromophoreSpectra& k = model_.chromophores();
  const double d = estimation::kEpidermisThicknessMm;
  const int r_count = static_cast<int>(radii_mm_.size());
  const int k_count = static_cast<int>(frequencies_per_mm_.size());
  Eigen::Matrix<double, Eigen::Dynamic, kGridSize> direct(r_count, kGridSize);  // R1(r) per wavelength
  Eigen::Matrix<double, kGridSize, Eigen::Dynamic> coupled(kGridSize, k_count);  // G(k) per wavelength

  for (int w = 0; w < kGridSize; ++w) {
    const double sa_epi = p.cm * (p.bm * k.sigma_a_eumelanin[w] + (1 - p.bm) * k.sigma_a_pheomelanin[w]) +
                          p.che * k.sigma_a_blood[w] + (1 - p.cm - p.che) * k.sigma_a_baseline[w];
    const double ss_epi = k.sigma_s_reduced_epidermis[w];
    const double st_epi = sa_epi + ss_epi;
    const double alpha = ss_epi / st_epi, l = 1.0 / st_epi, diffusion = l / 3.0;
    const double sigma_tr = std::sqrt(3.0 * sa_epi * st_epi);
    const double zb0 = 2.0 * skin_air_a_ * diffusion;
    const double period = 2.0 * (d + zb0 + 2.0 * estimation::kIndexMatchedA * diffusion);

    const double sa_derm = p.ch * k.sigma_a_blood[w] + (1 - p.ch) * k.sigma_a_baseline[w];
    const double ss_derm = k.sigma_s_reduced_dermis[w];
    const double st_derm = sa_derm + ss_derm;
    const double alpha_derm = ss_derm / st_derm, l_derm = 1.0 / st_derm;
    const double sigma_tr_derm = std::sqrt(3.0 * sa_derm * st_derm);
    const double zb_derm = 2.0 * estimation::kIndexMatchedA * l_derm / 3.0;

    // R1(r): the multipole in space. The pole depths are listed once, pairs
    // added until the largest term a pair could contribute (at r = 0) is
    // below 1e-12 of the first pole's.
    std::vector<double> depths{l, -l - 2.0 * zb0};  // signed; image poles carry a minus in the sum
    const double first = std::abs(pole_exitance(alpha, sigma_tr, l, 0.0));
    for (int n = 1; n < 10000; ++n) {
      double largest = 0;
      for (int s : {n, -n}) {
        const double zr = s * period + l, zv = s * period - l - 2.0 * zb0;
        depths.push_back(zr);
        depths.push_back(zv);
        largest = std::max({largest, std::abs(pole_exitance(alpha, sigma_tr, zr, 0.0)),
                            std::abs(pole_exitance(alpha, sigma_tr, zv, 0.0))});
      }
      if (largest < 1e-12 * first) break;
    }
    for (int i = 0; i < r_count; ++i) {
      double sum = 0;
      for (std::size_t pole = 0; pole < depths.size(); ++pole) {
        const double term = pole_exitance(alpha, sigma_tr, depths[pole], radii_mm_[i]);
        sum += (pole % 2 == 0) ? term : -term;  // real sources even, image sources odd
      }
      direct(i, w) = sum;
    }

    // G(k) = T1·R2·T1 / (1 - R1·R2) with σ → sqrt(σtr² + k²) in every layer,
    // vectorised over k.
    const Eigen::ArrayXd s_epi = (sigma_tr * sigma_tr + k_squared_).sqrt();
    auto family = [&](double c) {  // the ceil of family_sum, hoisted: z0 depends on c and P only
      const double z0 = std::ceil(-c / period) * period + c;
      if (z0 == 0.0) return Eigen::ArrayXd::Zero(k_count).eval();
      return (((-s_epi * z0).exp() - (-s_epi * (period - z0)).exp()) / (1.0 - (-s_epi * period).exp())).eval();
    };
    const Eigen::ArrayXd r1 = 0.5 * alpha * (family(l) - family(-l - 2.0 * zb0));
    const Eigen::ArrayXd t1 = 0.5 * alpha * (family(d - l) - family(d + l + 2.0 * zb0));
    const Eigen::ArrayXd s_derm = (sigma_tr_derm * sigma_tr_derm + k_squared_).sqrt();
    const Eigen::ArrayXd r2 = 0.5 * alpha_derm * ((-s_derm * l_derm).exp() + (-s_derm * (l_derm + 2.0 * zb_derm)).exp());
    coupled.row(w) = (t1 * r2 * t1 / (1.0 - r1 * r2)).matrix().transpose();
  }

  RadialProfile out;
  out.radius_mm = radii_mm_;
  // Project onto RGB first (everything is linear), then invert 3 transforms.
  const Eigen::Matrix<double, 3, Eigen::Dynamic> coupled_rgb = rgb_weights_ * coupled;
  out.rgb_per_mm2 = direct * rgb_weights_.transpose() + hankel_kernel_ * coupled_rgb.transpose();
  out.albedo_rgb = rgb_weights_ * model_.albedo(p).values().matrix();

  // ∫ R 2πr dr = ∫ R 2πr² d(ln r), trapezoid on the log grid, plus the disc
  // inside the first radius (R taken as constant there).
  const double log_step = std::log(radii_mm_[1] / radii_mm_[0]);
  out.plane_integral_rgb = out.rgb_per_mm2.row(0).transpose() * std::numbers::pi * radii_mm_[0] * radii_mm_[0];
  for (int i = 0; i < r_count; ++i) {
    const double weight = (i == 0 || i == r_count - 1) ? 0.5 : 1.0;
    out.plane_integral_rgb +=
        weight * log_step * 2.0 * std::numbers::pi * radii_mm_[i] * radii_mm_[i] * out.rgb_per_mm2.row(i).transpose();
  }
  return out;
}

}  // namespace chromo::maps
