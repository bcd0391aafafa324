// make_skin_scene: the virtual lab's skin patch. Every number here is a
// modelling choice of the virtual lab, documented in docs/camera.md.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "chromo/estimation/chromophores.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/simulators/scene/subsurface_spread.hpp"
#include "chromo/spectral/grid.hpp"

namespace chromo::simulators {
namespace {

using spectral::grid_wavelength_nm;
using spectral::kGridSize;
using spectral::Spectrum;

// A smooth random field in [-1, 1]: a few seeded plane waves.
class SmoothField {
 public:
  SmoothField(std::mt19937_64& rng, double min_period, double max_period) {
    std::uniform_real_distribution<double> angle(0, 2 * M_PI), period(min_period, max_period);
    for (auto& wave : waves_) wave = {angle(rng), 2 * M_PI / period(rng), angle(rng)};
  }
  double operator()(double x, double y) const {
    double sum = 0;
    for (const auto& w : waves_) sum += std::sin(w.k * (x * std::cos(w.direction) + y * std::sin(w.direction)) + w.phase);
    return sum / static_cast<double>(waves_.size());
  }

 private:
  struct Wave { double direction, k, phase; };
  std::array<Wave, 4> waves_{};
};

double distance_to_segment(double px, double py, double ax, double ay, double bx, double by) {
  const double vx = bx - ax, vy = by - ay;
  const double t = std::clamp(((px - ax) * vx + (py - ay) * vy) / (vx * vx + vy * vy + 1e-12), 0.0, 1.0);
  return std::hypot(px - ax - t * vx, py - ay - t * vy);
}

Spectrum gaussian_band(double centre_nm, double width_nm) {
  Spectrum s;
  for (int i = 0; i < kGridSize; ++i) s[i] = std::exp(-std::pow((grid_wavelength_nm(i) - centre_nm) / width_nm, 2));
  return s;
}

int thread_count(const SkinSceneOptions& options) {
  return options.threads > 0 ? options.threads : omp_get_max_threads();
}

}  // namespace

bool SkinSceneOptions::IsValid(std::string* error) const {
  if (width < 16 || height < 16 || width > 4096 || height > 4096) {
    if (error != nullptr) *error = "scene width and height must be 16-4096 pixels";
    return false;
  }
  if (row_begin < 0 || row_count < 0 || row_begin + row_count > height || (row_count == 0 && row_begin != 0)) {
    if (error != nullptr) *error = "rows: row_begin + row_count must lie within the scene's height";
    return false;
  }
  if (column_begin < 0 || column_count < 0 || column_begin + column_count > width ||
      (column_count == 0 && column_begin != 0)) {
    if (error != nullptr) *error = "columns: column_begin + column_count must lie within the scene's width";
    return false;
  }
  if (!(ch_factor > 0) || ch_change_width < 0 || ch_change_height < 0) {
    if (error != nullptr) *error = "ch_factor must be > 0 and the change's width and height >= 0";
    return false;
  }
  if (subsurface.on && !subsurface.IsValid(error)) return false;
  if (oily.count < 0 || oily.count > 64) {
    if (error != nullptr) *error = "oily.count must be 0-64";
    return false;
  }
  if (oily.count > 0 &&
      !(oily.sigma_reflectance > 0 && oily.min_sigma > 0 && oily.max_sigma >= oily.min_sigma &&
        oily.min_roughness_rad > 0 && oily.max_roughness_rad >= oily.min_roughness_rad && oily.min_radius_px >= 2 &&
        oily.max_radius_px >= oily.min_radius_px)) {
    if (error != nullptr)
      *error = "oily: sigma_reflectance > 0, 0 < min_sigma <= max_sigma, 0 < min_roughness_rad <= max_roughness_rad, "
               "2 <= min_radius_px <= max_radius_px";
    return false;
  }
  return true;
}

namespace {

struct OilyRegion {
  double x, y, radius, roughness_rad, strength;
};

// The regions of options.oily, from their own seeded stream (the scene's
// other features keep theirs), placed over the skin (left of the white strip).
std::vector<OilyRegion> oily_regions(const SkinSceneOptions& options) {
  std::vector<OilyRegion> regions;
  const OilyHighlights& o = options.oily;
  if (o.count == 0) return regions;
  std::mt19937_64 rng(options.seed ^ 0x6f696c79ULL);  // "oily"
  std::uniform_real_distribution<double> unit(0, 1);
  const double scale = options.width / 512.0;
  for (int k = 0; k < o.count; ++k) {
    const double share = o.count > 1 ? static_cast<double>(k) / (o.count - 1) : 0.0;
    const double n_sigma = o.min_sigma * std::pow(o.max_sigma / o.min_sigma, share);
    const double radius = (o.min_radius_px + (o.max_radius_px - o.min_radius_px) * unit(rng)) * scale;
    const double x = radius + unit(rng) * std::max(0.0, 0.88 * options.width - 2 * radius);
    const double y = radius + unit(rng) * std::max(0.0, options.height - 2 * radius);
    const double roughness = o.min_roughness_rad + (o.max_roughness_rad - o.min_roughness_rad) * unit(rng);
    regions.push_back({x, y, radius, roughness, n_sigma * o.sigma_reflectance});
  }
  return regions;
}

double standard_normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

}  // namespace

double skin_scene_oily_reflection(const SkinSceneOptions& options, double x, double y) {
  constexpr double kDomeTilt = 40 * M_PI / 180, kLitPolar = 70 * M_PI / 180, kFade = 0.2;
  double sum = 0;
  for (const OilyRegion& region : oily_regions(options)) {
    const double r = std::hypot(x - region.x, y - region.y) / region.radius;
    if (r >= 1) continue;
    const double coverage = std::clamp((1 - r) / kFade, 0.0, 1.0);
    const double mirror = 2 * kDomeTilt * r, spread = 2 * region.roughness_rad;
    const double lit = standard_normal_cdf((kLitPolar - mirror) / spread) / standard_normal_cdf(kLitPolar / spread);
    sum += region.strength * coverage * lit;
  }
  return sum;
}

double skin_scene_surface_highlight(const SkinSceneOptions& options, double x, double y) {
  const double highlight = options.highlight ? skin_scene_added_reflection(options.width, options.height, x, y) : 0.0;
  return (highlight > 0.006 ? highlight : 0.0) + skin_scene_oily_reflection(options, x, y);
}

Scene make_white_target_scene(int width, int height) {
  Scene scene(width, height);
  const Spectrum white = white_target_reflectance();
  scene.regions().setTo(cv::Scalar(static_cast<int>(SceneRegion::kWhiteTarget)));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) scene.set_albedo(x, y, white);
  return scene;
}

double skin_scene_added_reflection(int width, int height, double x, double y) {
  const double spec_x = 0.65 * width, spec_y = 0.2 * height, spec_rx = 0.08 * width, spec_ry = 0.04 * height;
  return 0.3 * std::exp(-(std::pow((x - spec_x) / spec_rx, 2) + std::pow((y - spec_y) / spec_ry, 2)));
}

double skin_scene_marker_cover(int width, int height, double x, double y) {
  const double half_width = 4 * width / 512.0;
  const double d = distance_to_segment(x, y, 0.5 * width, 0.85 * height, 0.85 * width, 0.6 * height);
  return std::clamp(half_width + 1 - d, 0.0, 1.0);
}

Scene make_skin_scene(const SkinSceneOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("SkinSceneOptions: " + error);
  const int w = options.width, h = options.height;
  const double scale = w / 512.0;  // geometry is laid out for 512 px and scaled
  // This scene's window [x0, x0 + cols) × [y0, y0 + rows) of the full w × h
  // scene; scene pixel = (x − x0, y − y0).
  const int y0 = options.row_begin, rows = options.row_count > 0 ? options.row_count : h;
  const int x0 = options.column_begin, cols = options.column_count > 0 ? options.column_count : w;
  Scene scene(cols, rows);
  std::mt19937_64 rng(options.seed);
  const SmoothField f_cm(rng, 120 * scale, 400 * scale), f_ch(rng, 80 * scale, 300 * scale),
      f_bm(rng, 150 * scale, 500 * scale), f_che(rng, 100 * scale, 400 * scale);
  std::uniform_real_distribution<double> unit(0, 1);

  // Moles: small dark spots (high Cm), explainable skin.
  struct Spot { double x, y, r; };
  std::vector<Spot> moles;
  for (int i = 0; i < 4; ++i) moles.push_back({unit(rng) * w * 0.85, unit(rng) * h, (3 + 4 * unit(rng)) * scale});

  // Vein: a gentle S-curve across the upper third; profile p in [0, 1].
  const double vein_y = 0.3 * h, vein_amplitude = 0.06 * h, vein_sigma = 6 * scale;
  auto vein_profile = [&](double x, double y) {
    const double centre = vein_y + vein_amplitude * std::sin(2 * M_PI * x / (0.9 * w));
    return std::exp(-std::pow((y - centre) / vein_sigma, 2));
  };

  // 1) Skin parameters everywhere (the truth maps).
  std::vector<estimation::SkinParameters> parameters(static_cast<std::size_t>(cols) * rows);
#pragma omp parallel for schedule(static) num_threads(thread_count(options))
  for (int y = y0; y < y0 + rows; ++y)
    for (int x = x0; x < x0 + cols; ++x) {
      estimation::SkinParameters p;
      p.cm = 0.05 + 0.03 * f_cm(x, y);
      p.ch = 0.025 + 0.015 * f_ch(x, y);
      p.bm = 0.7 + 0.1 * f_bm(x, y);
      p.che = 0.006 + 0.005 * f_che(x, y);
      for (const auto& m : moles) {
        const double d = std::hypot(x - m.x, y - m.y);
        if (d < m.r * 1.5) p.cm += 0.2 * std::exp(-std::pow(d / m.r, 2));
      }
      p.ch += 0.04 * vein_profile(x, y);  // the explainable part of the vein
      if (x >= options.ch_change_x && x < options.ch_change_x + options.ch_change_width && y >= options.ch_change_y &&
          y < options.ch_change_y + options.ch_change_height)
        p.ch *= options.ch_factor;
      parameters[static_cast<std::size_t>(y - y0) * cols + (x - x0)] = p;
      scene.cm().at<float>(y - y0, x - x0) = static_cast<float>(p.cm);
      scene.ch().at<float>(y - y0, x - x0) = static_cast<float>(p.ch);
      scene.bm().at<float>(y - y0, x - x0) = static_cast<float>(p.bm);
      scene.che().at<float>(y - y0, x - x0) = static_cast<float>(p.che);
    }

  // 2) Albedo straight from the forward model, in chunks (Spectrum is 648 bytes).
  const estimation::SkinModel model;
  constexpr std::size_t kChunk = 8192;
  std::vector<Spectrum> albedo(kChunk);
  for (std::size_t start = 0; start < parameters.size(); start += kChunk) {
    const std::size_t n = std::min(kChunk, parameters.size() - start);
    model.albedo_batch(std::span(parameters).subspan(start, n), std::span(albedo).first(n), options.threads);
    for (std::size_t i = 0; i < n; ++i) {
      const auto index = static_cast<int>(start + i);
      scene.set_albedo(index % cols, index / cols, albedo[i]);
    }
  }

  // 3) What the model cannot (fully) explain, painted over the skin albedo.
  // A pixel any of these touches carries that region's label (the last one
  // painted wins), so every kSkin pixel is exactly the model's albedo.
  const auto& chromophores = estimation::chromophore_spectra();
  Spectrum deoxy_attenuation;  // deeper deoxygenated blood: extra absorption the model (γ = 0.75) lacks
  for (int i = 0; i < kGridSize; ++i) {
    const double s = chromophores.sigma_a_deoxy_blood[i];
    deoxy_attenuation[i] = s / (s + 1.0);
  }
  Spectrum ink;  // blue-black tattoo ink
  const Spectrum ink_band = gaussian_band(470, 40);
  for (int i = 0; i < kGridSize; ++i) ink[i] = 0.04 + 0.08 * ink_band[i];
  const Spectrum dye_absorption = gaussian_band(590, 45);  // gentian-violet surgical marker
  Spectrum dye_double_pass;
  for (int i = 0; i < kGridSize; ++i) dye_double_pass[i] = std::pow(1.0 - 0.75 * dye_absorption[i], 2);
  Spectrum hair;  // dark brown strands
  for (int i = 0; i < kGridSize; ++i) hair[i] = 0.03 + 0.07 * (grid_wavelength_nm(i) - 380.0) / 400.0;

  // Tattoo: a disk in the lower left; marker: a stroke across the lower right;
  // hair strands: random segments; specular: an ellipse in the upper right.
  const double tattoo_x = 0.25 * w, tattoo_y = 0.7 * h, tattoo_r = 0.1 * w;
  struct Strand { double ax, ay, bx, by; };
  std::vector<Strand> strands;
  for (int i = 0; i < 12; ++i) {
    const double ax = unit(rng) * 0.85 * w, ay = unit(rng) * h, angle = unit(rng) * 2 * M_PI, length = (40 + 60 * unit(rng)) * scale;
    strands.push_back({ax, ay, ax + length * std::cos(angle), ay + length * std::sin(angle)});
  }
  const double hair_half_width = std::max(1.5 * scale, 1.0);
  const Spectrum white = white_target_reflectance();
  const int white_x0 = options.white_patch ? w - w / 10 : w;

#pragma omp parallel for schedule(static) num_threads(thread_count(options))
  for (int y = y0; y < y0 + rows; ++y)
    for (int x = x0; x < x0 + cols; ++x) {
      const Spectrum skin = scene.albedo_at(x - x0, y - y0);
      Spectrum a = skin;
      SceneRegion region = SceneRegion::kSkin;
      const double vein = vein_profile(x, y);
      if (vein > 0.05) {
        for (int i = 0; i < kGridSize; ++i) a[i] *= 1.0 - 0.45 * vein * deoxy_attenuation[i];
        region = SceneRegion::kVein;
      }
      const double tattoo = std::clamp((tattoo_r - std::hypot(x - tattoo_x, y - tattoo_y)) / (3 * scale), 0.0, 1.0) * 0.85;
      if (tattoo > 0) {
        a = (1 - tattoo) * a + tattoo * ink;
        region = SceneRegion::kTattoo;
      }
      const double marker_cover = skin_scene_marker_cover(w, h, x, y);
      if (marker_cover > 0) {
        for (int i = 0; i < kGridSize; ++i) a[i] *= 1 - marker_cover + marker_cover * dye_double_pass[i];
        region = SceneRegion::kMarker;
      }
      double hair_cover = 0;
      for (const auto& s : strands)
        hair_cover = std::max(hair_cover, std::clamp(hair_half_width - distance_to_segment(x, y, s.ax, s.ay, s.bx, s.by), 0.0, 1.0) * 0.9);
      if (hair_cover > 0) {
        a = (1 - hair_cover) * a + hair_cover * hair;
        region = SceneRegion::kHair;
      }
      const double reflection = skin_scene_surface_highlight(options, x, y);
      if (reflection > 0) {
        a += Spectrum::constant(reflection);  // surface reflection: flat, on top of the diffuse albedo
        region = SceneRegion::kSpecular;
      }
      if (!options.anomalies) a = skin;  // labelled as above, the skin model's albedo beneath
      if (x >= white_x0) {
        a = white;
        region = SceneRegion::kWhiteTarget;
      }
      scene.set_albedo(x - x0, y - y0, a);
      scene.regions().at<std::uint8_t>(y - y0, x - x0) = static_cast<std::uint8_t>(region);
    }
  if (options.subsurface.on) {
    const cv::Mat skin_side = scene.regions() != static_cast<int>(SceneRegion::kWhiteTarget);
    apply_subsurface_spread(scene, options.subsurface, skin_side, [&](int x, int y) {
      return options.anomalies ? skin_scene_surface_highlight(options, x + x0, y + y0) : 0.0;
    });
  }
  return scene;
}

SkinSceneResponse render_skin_scene_bands(const SkinSceneOptions& options, const std::vector<int>& channels, int band_rows,
                                          const BandRender& render) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("SkinSceneOptions: " + error);
  if (band_rows < 1) throw std::invalid_argument("render_skin_scene: band_rows must be >= 1");
  const int first = options.row_begin, rows = options.row_count > 0 ? options.row_count : options.height;
  const int cols = options.column_count > 0 ? options.column_count : options.width;
  SkinSceneResponse out;
  for (int n : channels) out.responses.emplace_back(rows, cols, CV_32FC(n));
  out.regions.create(rows, cols, CV_8U);
  for (cv::Mat* m : {&out.cm, &out.ch, &out.bm, &out.che}) m->create(rows, cols, CV_32F);
  // With subsurface spread each band is made with 3σ of the red's spread
  // more rows on both sides (within the scene) and cropped, so the bands
  // meet without seams.
  const int margin = options.subsurface.on ? static_cast<int>(std::ceil(3 * options.subsurface.sigma_red_px)) : 0;
  for (int y = 0; y < rows; y += band_rows) {
    const int row_count = std::min(band_rows, rows - y);
    SkinSceneOptions band = options;
    band.row_begin = std::max(0, first + y - margin);
    band.row_count = std::min(options.height, first + y + row_count + margin) - band.row_begin;
    const Scene scene = make_skin_scene(band);
    const cv::Rect source(0, first + y - band.row_begin, cols, row_count), target(0, y, cols, row_count);
    for (std::size_t k = 0; k < channels.size(); ++k) render(scene, band, k)(source).copyTo(out.responses[k](target));
    scene.regions()(source).copyTo(out.regions(target));
    scene.cm()(source).copyTo(out.cm(target));
    scene.ch()(source).copyTo(out.ch(target));
    scene.bm()(source).copyTo(out.bm(target));
    scene.che()(source).copyTo(out.che(target));
  }
  return out;
}

SkinSceneResponse render_skin_scene(const SkinSceneOptions& options, const std::vector<SceneWeights>& weights,
                                    int band_rows) {
  std::vector<int> channels;
  for (const SceneWeights& w : weights) channels.push_back(static_cast<int>(w.rows()));
  return render_skin_scene_bands(options, channels, band_rows,
                                 [&](const Scene& scene, const SkinSceneOptions&, std::size_t k) { return scene.render(weights[k]); });
}

}  // namespace chromo::simulators
