#include "chromo/simulators/polarisation/polarised_skin.hpp"

#include <numbers>
#include <stdexcept>
#include <vector>

#include "chromo/simulators/polarisation/skin_surface.hpp"

namespace chromo::simulators {
namespace {

bool is_white_target(const Scene& scene, int x, int y) {
  return scene.regions().at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(SceneRegion::kWhiteTarget);
}

// The highlight make_skin_scene added to pixel (x, y) of its window (0 where it added none).
double added_highlight(const Scene& scene, const SkinSceneOptions& options, int x, int y) {
  if (scene.regions().at<std::uint8_t>(y, x) != static_cast<std::uint8_t>(SceneRegion::kSpecular)) return 0;
  return skin_scene_surface_highlight(options, x + options.column_begin, y + options.row_begin);
}

}  // namespace

cv::Mat skin_surface_layer(const Scene& scene, const SkinSceneOptions& options, double view_angle_deg) {
  const double sheen =
      fresnel_reflectance_unpolarised(kSkinRefractiveIndex, view_angle_deg * std::numbers::pi / 180.0);
  cv::Mat surface(scene.height(), scene.width(), CV_32F);
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x)
      surface.at<float>(y, x) =
          is_white_target(scene, x, y) ? 0.0f : static_cast<float>(sheen + added_highlight(scene, options, x, y));
  return surface;
}

cv::Mat render_polarised_skin(const Scene& scene, const SkinSceneOptions& options, const SceneWeights& weights,
                              drivers::Polarisation state, const std::optional<PolarisedSphere>& sphere) {
  if (!sphere) return scene.render(weights);  // the unpolarised sphere: the old path
  const auto channels = static_cast<int>(weights.rows());
  if (channels < 1 || channels > 4) throw std::invalid_argument("render_polarised_skin: 1-4 weight rows");
  if (scene.width() != (options.column_count ? options.column_count : options.width) ||
      scene.height() != (options.row_count ? options.row_count : options.height))
    throw std::invalid_argument("render_polarised_skin: the scene is not make_skin_scene(options)");
  const spectral::Spectrum transmission = sphere->light_film_in_illumination
                                              ? sphere->analyser_film.transmission()
                                              : diffuse_transmission(sphere->light_film, sphere->analyser_film);
  const spectral::Spectrum factor =
      surface_factor_in_albedo(state, sphere->light_film, sphere->analyser_film, sphere->cross_leak);
  // Per channel: the weights through both films, and what a surface reflection of 1 gives.
  std::vector<double> filtered(static_cast<std::size_t>(channels) * spectral::kGridSize);
  std::vector<double> surface_response(channels, 0.0), flat_response(channels, 0.0);
  for (int c = 0; c < channels; ++c)
    for (int i = 0; i < spectral::kGridSize; ++i) {
      const double w = weights(c, i) * transmission[i];
      filtered[c * spectral::kGridSize + i] = w;
      surface_response[c] += w * factor[i];
      flat_response[c] += w;
    }
  const cv::Mat surface = skin_surface_layer(scene, options, sphere->view_angle_deg);
  cv::Mat out(scene.height(), scene.width(), CV_32FC(channels));
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x) {
      const float* albedo = scene.albedo_data() + (static_cast<std::size_t>(y) * scene.width() + x) * spectral::kGridSize;
      const double highlight = added_highlight(scene, options, x, y);  // in the albedo: not diffuse
      float* result = out.ptr<float>(y) + static_cast<std::size_t>(x) * channels;
      for (int c = 0; c < channels; ++c) {
        double sum = 0;
        for (int i = 0; i < spectral::kGridSize; ++i) sum += filtered[c * spectral::kGridSize + i] * albedo[i];
        sum += (surface.at<float>(y, x) * surface_response[c]) - highlight * flat_response[c];
        result[c] = static_cast<float>(sum);
      }
    }
  return out;
}

SkinSceneResponse render_polarised_skin_scene(const SkinSceneOptions& options, const std::vector<SceneWeights>& weights,
                                              const std::vector<drivers::Polarisation>& states,
                                              const std::optional<PolarisedSphere>& sphere, int band_rows) {
  if (!sphere) return render_skin_scene(options, weights, band_rows);
  if (states.size() != weights.size())
    throw std::invalid_argument("render_polarised_skin_scene: one polarisation state per weights matrix");
  std::vector<int> channels;
  for (const SceneWeights& w : weights) channels.push_back(static_cast<int>(w.rows()));
  return render_skin_scene_bands(options, channels, band_rows,
                                 [&](const Scene& scene, const SkinSceneOptions& band, std::size_t k) {
                                   return render_polarised_skin(scene, band, weights[k], states[k], sphere);
                                 });
}

}  // namespace chromo::simulators
