#include "chromo/simulators/scene/external_maps_scene.hpp"

#include <opencv2/imgcodecs.hpp>
#include <cmath>
#include <fstream>
#include <random>
#include <stdexcept>

#include "chromo/files/float_image.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/files/output_batch.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/grid.hpp"

namespace chromo::simulators {

namespace {
void write_png(const std::string& path, const cv::Mat& image) {
  if (!cv::imwrite(path, image)) throw std::runtime_error(path + ": cannot write PNG");
}
}  // namespace

void write_external_maps_scene(const std::filesystem::path& directory, const ExternalMapsSceneOptions& options) {
  if (!(options.camera_noise_scale >= 0) || !(options.map_noise_fraction >= 0))
    throw std::invalid_argument("noise scales must be ≥ 0");
  SkinSceneOptions scene_options;
  scene_options.width = options.width, scene_options.height = options.height;
  scene_options.seed = options.seed, scene_options.white_patch = false, scene_options.threads = options.threads;
  scene_options.ch_factor = options.ch_factor;
  scene_options.ch_change_x = options.ch_change_x, scene_options.ch_change_y = options.ch_change_y;
  scene_options.ch_change_width = options.ch_change_width, scene_options.ch_change_height = options.ch_change_height;
  const Scene scene = make_skin_scene(scene_options);
  const int w = scene.width(), h = scene.height();
  const std::size_t pixels = static_cast<std::size_t>(w) * h;

  CameraNoiseModel camera_noise;
  camera_noise.noise_scale = options.camera_noise_scale;
  const spectral::Spectrum d65_prime = spectral::led_d65_metamer();
  const spectral::Spectrum blue = spectral::led_spectrum(spectral::LedType::kBlue);
  const estimation::MeasurementSet set = estimation::method_measurement_set(
      spectral::builtin_camera("nikon_d5100"), d65_prime, blue, camera_noise.channel_noise());
  const cv::Mat rendered = scene.render(set.weights());  // CV_32FC4: R, G, B under D65', B under blue

  std::mt19937_64 rng((options.noise_seed ? options.noise_seed : options.seed) * 7919 + 1);
  std::normal_distribution<double> gauss(0.0, 1.0);
  auto noisy = [&](double albedo, const estimation::ChannelNoise& noise) {
    return static_cast<float>(options.camera_noise_scale > 0 ? albedo + std::sqrt(noise.variance(albedo)) * gauss(rng)
                                                             : albedo);
  };
  files::FloatImage broadband{w, h, {"R", "G", "B"}, std::vector<std::vector<float>>(3, std::vector<float>(pixels))};
  files::FloatImage blue_only{w, h, {"B"}, std::vector<std::vector<float>>(1, std::vector<float>(pixels))};
  for (std::size_t i = 0; i < pixels; ++i) {
    const cv::Vec4f v = rendered.at<cv::Vec4f>(static_cast<int>(i));
    for (int c = 0; c < 3; ++c) broadband.channels[c][i] = noisy(v[c], set.channels[c].noise);
    blue_only.channels[0][i] = noisy(v[3], set.channels[3].noise);
  }

  files::FloatImage truth{w, h, {"Cm", "Ch", "Bm", "Che", "flags", "region"},
                               std::vector<std::vector<float>>(6, std::vector<float>(pixels, 0.0f))};
  cv::Mat melanin(h, w, CV_16U), hemoglobin(h, w, CV_16U), skin(h, w, CV_8U);
  auto to_u16 = [](double v) { return static_cast<std::uint16_t>(std::lround(std::clamp(v, 0.0, 65535.0))); };
  for (std::size_t i = 0; i < pixels; ++i) {
    const int idx = static_cast<int>(i);
    const double cm = scene.cm().at<float>(idx), ch = scene.ch().at<float>(idx), bm = scene.bm().at<float>(idx),
                 che = scene.che().at<float>(idx);
    truth.channels[0][i] = static_cast<float>(cm), truth.channels[1][i] = static_cast<float>(ch);
    truth.channels[2][i] = static_cast<float>(bm), truth.channels[3][i] = static_cast<float>(che);
    truth.channels[5][i] = scene.regions().at<std::uint8_t>(idx);
    skin.at<std::uint8_t>(idx) = scene.regions().at<std::uint8_t>(idx) == static_cast<std::uint8_t>(SceneRegion::kSkin) ? 255 : 0;
    const double noise = 60000.0 * options.map_noise_fraction;
    melanin.at<std::uint16_t>(idx) = to_u16(60000.0 * std::pow(1.0 - std::exp(-cm / 0.06), 0.7) + noise * gauss(rng));
    hemoglobin.at<std::uint16_t>(idx) =
        to_u16(60000.0 * std::sqrt(ch / (ch + 0.04)) * (1.0 + 0.05 * (bm - 0.7)) + noise * gauss(rng));
  }

  auto spectrum_csv = [](const spectral::Spectrum& s) {
    std::string text = "# relative spectral power on the project grid (write_external_maps_scene)\nwavelength_nm,value\n";
    for (int i = 0; i < spectral::kGridSize; ++i)
      text += std::to_string(static_cast<int>(spectral::grid_wavelength_nm(i))) + "," + std::to_string(s[i]) + "\n";
    return text;
  };
  // The file states the camera's nominal noise even for noise-free data (the
  // estimator weighs channels by it).
  const estimation::MeasurementSet nominal = estimation::method_measurement_set(
      set.camera, d65_prime, blue, CameraNoiseModel{}.channel_noise());
  const auto& noise = nominal.channels[0].noise;
  const std::string measurement =
      "{\n  \"camera\": \"builtin:nikon_d5100\",\n  \"noise\": {\"read_sigma\": " + std::to_string(noise.read_sigma) +
      ", \"shot_coefficient\": " + std::to_string(noise.shot_coefficient) +
      ", \"saturation_albedo\": " + std::to_string(noise.saturation_albedo) +
      "},\n  \"images\": [\n    {\"name\": \"D65'\", \"file\": \"d65prime.exr\", \"illuminant\": \"d65prime.csv\", "
      "\"channels\": [\"R\", \"G\", \"B\"]},\n    {\"name\": \"blue\", \"file\": \"blue.exr\", \"illuminant\": "
      "\"blue.csv\", \"channels\": [\"B\"], \"noise\": {\"read_sigma\": " +
      std::to_string(nominal.channels[3].noise.read_sigma) + "}}\n  ]\n}\n";

  files::OutputBatch files(directory);
  files::write_exr(files.temporary("d65prime.exr"), broadband);
  files::write_exr(files.temporary("blue.exr"), blue_only);
  files::write_exr(files.temporary("truth.exr"), truth);
  write_png(files.temporary("melanin.png").string(), melanin);
  write_png(files.temporary("hemoglobin.png").string(), hemoglobin);
  write_png(files.temporary("skin_mask.png").string(), skin);
  files.write_text("d65prime.csv", spectrum_csv(d65_prime));
  files.write_text("blue.csv", spectrum_csv(blue));
  files.write_text("MEASUREMENT.json", measurement);
  files.commit();
}

}  // namespace chromo::simulators
