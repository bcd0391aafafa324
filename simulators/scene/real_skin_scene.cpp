#include "chromo/simulators/scene/real_skin_scene.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <random>
#include <set>
#include <stdexcept>

#include "chromo/files/float_image.hpp"
#include "chromo/files/output_batch.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/grid.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::simulators {
namespace {

enum Region : std::uint8_t { kSkinRegion = 0, kTattooRegion = 1, kMarkerRegion = 2 };

struct Image {
  std::string name, file;
  spectral::Spectrum illuminant;
  std::vector<std::string> channels;
  double read_factor = 1;  // the method's blue-only image is a difference of two captures
};

std::vector<Image> plan_images(const std::string& plan) {
  if (plan == "method")
    return {{"D65'", "d65prime", spectral::led_d65_metamer(), {"R", "G", "B"}, 1},
            {"blue", "blue", spectral::led_spectrum(spectral::LedType::kBlue), {"B"}, std::sqrt(2.0)}};
  std::vector<Image> out;
  for (auto type : spectral::kAllLedTypes) {
    const std::string name(spectral::led_type_name(type));
    out.push_back({name, name, spectral::led_spectrum(type), {"R", "G", "B"}, 1});
  }
  return out;
}

CameraNoiseModel scene_noise(double scale) {
  CameraNoiseModel n;
  n.electrons_at_full_scale = 4 * 40000.0;  // four frames of a 40,000 e⁻ sensor
  n.read_noise_electrons = 12;              // 6 e⁻ per frame, four frames summed
  n.noise_scale = scale;
  return n;
}

std::string spectrum_csv(const spectral::Spectrum& s, const std::string& what) {
  std::string text = "# " + what + ": relative spectral power on the project grid (write_real_skin_scene)\nwavelength_nm,value\n";
  for (int i = 0; i < spectral::kGridSize; ++i)
    text += std::to_string(static_cast<int>(spectral::grid_wavelength_nm(i))) + "," + std::to_string(s[i]) + "\n";
  return text;
}

}  // namespace

bool RealSkinSceneOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (spectra.empty()) return fail("spectra: no skin spectrum given");
  if (spectra.size() > 400) return fail("spectra: at most 400 patches, got " + std::to_string(spectra.size()));
  if (patch_px < 8 || patch_px > 512) return fail("patch_px must be in [8, 512]");
  if (columns < 1 || columns > 64) return fail("columns must be in [1, 64]");
  if (plan != "method" && plan != "six-leds") return fail("plan must be method or six-leds, got \"" + plan + "\"");
  if (!(texture_relative >= 0 && texture_relative < 0.5)) return fail("texture_relative must be in [0, 0.5)");
  if (!(noise_scale >= 0 && noise_scale <= 100)) return fail("noise_scale must be in [0, 100]");
  for (const auto& s : spectra)
    if (!s.albedo.values().allFinite() || s.albedo.min() < 0 || s.albedo.max() > 1.5)
      return fail("spectra: " + s.name + " is not an albedo within [0, 1.5]");
  return true;
}

std::vector<estimation::NamedSpectrum> nist_subjects(const std::string& selection) {
  const auto& all = estimation::nist_forearm_spectra();
  auto find = [&](int number) -> const estimation::NamedSpectrum& {
    char name[32];
    std::snprintf(name, sizeof name, "subject_%03d", number);
    for (const auto& s : all)
      if (s.name == name) return s;
    throw std::invalid_argument(std::string("subjects: no NIST subject ") + name + " (shipped: subject_001-subject_050)");
  };
  auto number = [&](const std::string& text) {
    std::size_t used = 0;
    int n = 0;
    try {
      n = std::stoi(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != text.size()) throw std::invalid_argument("subjects: \"" + text + "\" is not a subject number");
    return n;
  };
  std::vector<estimation::NamedSpectrum> out;
  const auto dash = selection.find('-');
  if (dash != std::string::npos) {
    const int first = number(selection.substr(0, dash)), last = number(selection.substr(dash + 1));
    if (last < first) throw std::invalid_argument("subjects: the range " + selection + " is empty");
    for (int n = first; n <= last; ++n) out.push_back(find(n));
    return out;
  }
  std::size_t start = 0;
  while (start <= selection.size()) {
    const auto comma = selection.find(',', start);
    out.push_back(find(number(selection.substr(start, comma == std::string::npos ? std::string::npos : comma - start))));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

void write_real_skin_scene(const std::filesystem::path& directory, const RealSkinSceneOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("real skin scene: " + error);
  const int patches = static_cast<int>(options.spectra.size());
  const int columns = std::min(options.columns, patches);
  const int rows = (patches + columns - 1) / columns;
  const int p = options.patch_px, w = columns * p, h = rows * p;
  const std::size_t pixels = static_cast<std::size_t>(w) * h;
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  const std::vector<Image> images = plan_images(options.plan);

  // Per pixel: the patch, the texture scale and the region.
  std::vector<int> patch(pixels, -1);
  std::vector<float> scale(pixels, 0.0f);
  std::vector<std::uint8_t> region(pixels, kSkinRegion);
  std::mt19937_64 rng(options.seed * 6364136223846793005ULL + 1442695040888963407ULL);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const double tattoo_x = 0.3 * w, tattoo_y = 0.5 * h, tattoo_r = 0.6 * p;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      const int k = (y / p) * columns + x / p;
      scale[i] = static_cast<float>(1 + options.texture_relative * uniform(rng));
      if (k >= patches) continue;
      patch[i] = k;
      if (!options.anomalies) continue;
      if (std::hypot(x + 0.5 - tattoo_x, y + 0.5 - tattoo_y) < tattoo_r) region[i] = kTattooRegion;
      else if (std::abs(y + 0.5 - 0.75 * h) < std::max(1.5, 0.1 * p) && x > 0.1 * w && x < 0.9 * w) region[i] = kMarkerRegion;
    }
  const spectral::GridArray tattoo = anomaly_albedo_factor(SyntheticKind::kTattoo),
                            marker = anomaly_albedo_factor(SyntheticKind::kMarker);

  const CameraNoiseModel noise_model = scene_noise(options.noise_scale);
  const estimation::ChannelNoise noise = noise_model.channel_noise();
  const estimation::ChannelNoise declared = options.noise_scale > 0 ? noise : scene_noise(1).channel_noise();
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double step = noise_model.full_scale_albedo / 4095.0;
  files::OutputBatch batch(directory);
  nlohmann::ordered_json measurement;
  measurement["camera"] = "builtin:nikon_d5100";
  measurement["noise"] = {{"read_sigma", declared.read_sigma},
                          {"shot_coefficient", declared.shot_coefficient},
                          {"saturation_albedo", declared.saturation_albedo}};
  measurement["images"] = nlohmann::ordered_json::array();
  for (const Image& image : images) {
    const spectral::CameraWeights weights = spectral::camera_weights(camera, image.illuminant);
    files::FloatImage out{w, h, {"R", "G", "B"}, std::vector<std::vector<float>>(3, std::vector<float>(pixels, 0.0f))};
    std::mt19937_64 image_rng(options.seed * 1000003 + std::hash<std::string>{}(image.name));
    for (std::size_t i = 0; i < pixels; ++i) {
      if (patch[i] < 0) continue;  // outside the patches: black (dark)
      spectral::GridArray albedo = options.spectra[patch[i]].albedo.values() * scale[i];
      if (region[i] == kTattooRegion) albedo *= tattoo;
      if (region[i] == kMarkerRegion) albedo *= marker;
      const Eigen::Vector3d rgb = weights * albedo.matrix();
      for (int c = 0; c < 3; ++c) {
        double v = rgb[c];
        if (options.noise_scale > 0) {
          const double sigma = std::sqrt(std::pow(noise.read_sigma * image.read_factor, 2) + noise.shot_coefficient * std::max(v, 0.0));
          v = std::clamp(std::round((v + sigma * gauss(image_rng)) / step) * step, 0.0, noise_model.full_scale_albedo);
        }
        out.channels[c][i] = static_cast<float>(v);
      }
    }
    files::write_exr(batch.temporary(image.file + ".exr"), out);
    batch.write_text(image.file + ".csv", spectrum_csv(image.illuminant, image.name));
    nlohmann::ordered_json entry{{"name", image.name}, {"file", image.file + ".exr"}, {"illuminant", image.file + ".csv"},
                                 {"channels", image.channels}};
    if (image.read_factor != 1) entry["noise"] = {{"read_sigma", declared.read_sigma * image.read_factor}};
    measurement["images"].push_back(entry);
  }
  files::FloatImage truth{w, h, {"spectrum", "scale", "region"}, std::vector<std::vector<float>>(3, std::vector<float>(pixels))};
  cv::Mat skin(h, w, CV_8U, cv::Scalar(0));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      truth.channels[0][i] = static_cast<float>(patch[i]);
      truth.channels[1][i] = scale[i];
      truth.channels[2][i] = region[i];
      const int inside = std::min({x % p, p - 1 - x % p, y % p, p - 1 - y % p});
      bool clear = patch[i] >= 0 && inside >= 2;
      for (int dy = -2; clear && dy <= 2; ++dy)
        for (int dx = -2; clear && dx <= 2; ++dx) {
          const int yy = std::clamp(y + dy, 0, h - 1), xx = std::clamp(x + dx, 0, w - 1);
          clear = region[static_cast<std::size_t>(yy) * w + xx] == kSkinRegion;
        }
      skin.at<std::uint8_t>(y, x) = clear ? 255 : 0;
    }
  files::write_exr(batch.temporary("truth.exr"), truth);
  if (!cv::imwrite(batch.temporary("skin_mask.png").string(), skin)) throw std::runtime_error("skin_mask.png: cannot write PNG");
  nlohmann::ordered_json subjects = nlohmann::ordered_json::array();
  for (const auto& s : options.spectra) subjects.push_back(s.name);
  measurement["scene"] = {{"kind", "real skin spectra"},
                          {"spectra", subjects},
                          {"patch_px", p},
                          {"texture_relative", options.texture_relative},
                          {"noise_scale", options.noise_scale},
                          {"plan", options.plan},
                          {"seed", options.seed}};
  batch.write_text("MEASUREMENT.json", measurement.dump(2) + "\n");
  batch.commit();
}

}  // namespace chromo::simulators
