#include "chromo/session/measurement_file.hpp"
#include "chromo/files/bounded_read.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::session {
namespace fs = std::filesystem;
namespace {

std::string fmt_number(double v) {
  std::string s = std::to_string(v);
  while (s.size() > 1 && s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s;
}

int channel_index(const std::string& name) { return name == "R" ? 0 : name == "G" ? 1 : 2; }

estimation::ChannelNoise parse_noise(const nlohmann::json& j, estimation::ChannelNoise base, const std::string& where) {
  if (j.is_null()) return base;
  if (!j.is_object()) throw MeasurementFileError(where + ": 'noise' must be an object");
  for (const auto& item : j.items()) {
    const std::string key = item.key();
    const nlohmann::json& value = item.value();
    if (!value.is_number()) throw MeasurementFileError(where + ": noise." + key + " must be a number");
    const double v = value.get<double>();
    // Refused where they enter (docs/formats/measurement.md): albedo units, so
    // anything outside these ranges is a mistake, not a noisy camera.
    auto in_range = [&](double low, bool low_open, double high) {
      if (!std::isfinite(v) || (low_open ? !(v > low) : !(v >= low)) || !(v <= high))
        throw MeasurementFileError(where + ": noise." + key + ": " + value.dump() + " is outside " +
                                   (low_open ? "(" : "[") + fmt_number(low) + ", " + fmt_number(high) + "]");
      return v;
    };
    if (key == "read_sigma") base.read_sigma = in_range(0, false, 1);
    else if (key == "shot_coefficient") base.shot_coefficient = in_range(0, false, 1);
    else if (key == "white_coefficient") base.white_coefficient = in_range(0, false, 1);
    else if (key == "saturation_albedo") base.saturation_albedo = in_range(0, true, 10);
    else
      throw MeasurementFileError(where + ": unknown noise key '" + key +
                                 "' (read_sigma, shot_coefficient, white_coefficient, saturation_albedo)");
  }
  return base;
}

}  // namespace

spectral::CameraSensitivity camera_by_name_or_file(const std::string& text, const fs::path& base) {
  if (text.rfind("builtin:", 0) == 0) return spectral::builtin_camera(text.substr(8));
  const fs::path p(text);
  return spectral::read_camera_sensitivity(p.is_absolute() ? p : base / p);
}

estimation::MeasurementSet MeasurementFile::measurement_set() const {
  estimation::MeasurementSet set{camera, {}};
  for (const MeasurementImage& image : images)
    for (const auto& c : image.channels)
      set.channels.push_back({image.name + "." + c, image.illuminant, channel_index(c), image.noise});
  return set;
}

std::vector<float> MeasurementFile::pixel_major() const {
  std::vector<const std::vector<float>*> planes;
  for (const MeasurementImage& image : images)
    for (const auto& c : image.channels) planes.push_back(&image.pixels.channel(c));
  const std::size_t pixels = static_cast<std::size_t>(width) * height, channels = planes.size();
  std::vector<float> out(pixels * channels);
  for (std::size_t i = 0; i < pixels; ++i)
    for (std::size_t c = 0; c < channels; ++c) out[i * channels + c] = (*planes[c])[i];
  return out;
}

MeasurementFile read_measurement_file(const fs::path& file) {
  std::string text;
  try {
    text = files::read_text_file(file, "JSON");
  } catch (const files::InputFileError& e) {
    throw MeasurementFileError(e.what());
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw MeasurementFileError(file.string() + ": not valid JSON: " + e.what());
  }
  if (!j.is_object()) throw MeasurementFileError(file.string() + ": must be a JSON object");
  const fs::path base = file.parent_path();
  auto resolve = [&](const std::string& p) { return fs::path(p).is_absolute() ? fs::path(p) : base / p; };
  auto need_string = [&](const nlohmann::json& o, const char* key, const std::string& where) {
    if (!o.contains(key) || !o[key].is_string()) throw MeasurementFileError(where + ": missing string '" + key + "'");
    return o[key].get<std::string>();
  };
  MeasurementFile m;
  try {
    m.camera = camera_by_name_or_file(need_string(j, "camera", file.string()), base);
  } catch (const spectral::DataError& e) {
    throw MeasurementFileError(std::string("camera: ") + e.what());
  }
  const estimation::ChannelNoise default_noise = parse_noise(j.value("noise", nlohmann::json()), {}, file.string());
  if (!j.contains("images") || !j["images"].is_array() || j["images"].empty())
    throw MeasurementFileError(file.string() + ": 'images' must be a non-empty array");
  std::size_t listed = 0;
  for (const auto& o : j["images"])
    if (o.is_object() && o.contains("channels") && o["channels"].is_array()) listed += o["channels"].size();
  if (j["images"].size() > kMaxMeasurementChannels || listed > kMaxMeasurementChannels)
    throw MeasurementFileError(file.string() + ": images: " + std::to_string(j["images"].size()) + " images with " +
                               std::to_string(listed) + " channels, over the cap of " +
                               std::to_string(kMaxMeasurementChannels) +
                               " channels (the largest built-in plan has 27)");
  for (std::size_t k = 0; k < j["images"].size(); ++k) {
    const nlohmann::json& o = j["images"][k];
    const std::string where = file.string() + ": images[" + std::to_string(k) + "]";
    if (!o.is_object()) throw MeasurementFileError(where + " must be an object");
    MeasurementImage image;
    if (o.contains("name") && !o["name"].is_string()) throw MeasurementFileError(where + ": 'name' must be a string");
    image.name = o.value("name", "image" + std::to_string(k));
    try {
      image.pixels = files::read_exr(resolve(need_string(o, "file", where)));
      image.illuminant = spectral::read_spectrum_file(resolve(need_string(o, "illuminant", where)));
    } catch (const files::ImageError& e) {
      throw MeasurementFileError(where + ": " + e.what());
    } catch (const spectral::DataError& e) {
      throw MeasurementFileError(where + ": illuminant: " + e.what());
    }
    if (!o.contains("channels") || !o["channels"].is_array() || o["channels"].empty())
      throw MeasurementFileError(where + ": 'channels' must be a non-empty array of \"R\", \"G\", \"B\"");
    for (const auto& c : o["channels"]) {
      if (!c.is_string() || (c != "R" && c != "G" && c != "B"))
        throw MeasurementFileError(where + ": channel " + c.dump() + " is not \"R\", \"G\" or \"B\"");
      try {
        image.pixels.channel(c.get<std::string>());
      } catch (const files::ImageError& e) {
        throw MeasurementFileError(where + ": " + e.what());
      }
      image.channels.push_back(c.get<std::string>());
    }
    image.noise = parse_noise(o.value("noise", nlohmann::json()), default_noise, where);
    if (k == 0) m.width = image.pixels.width, m.height = image.pixels.height;
    if (image.pixels.width != m.width || image.pixels.height != m.height)
      throw MeasurementFileError(where + ": " + std::to_string(image.pixels.width) + "×" +
                                 std::to_string(image.pixels.height) + " pixels, but images[0] has " +
                                 std::to_string(m.width) + "×" + std::to_string(m.height));
    m.images.push_back(std::move(image));
  }
  return m;
}

std::vector<RegistrationReport> register_images(MeasurementFile& m, const RegistrationOptions& options) {
  std::vector<RegistrationReport> out;
  const MeasurementImage& first = m.images.front();
  for (std::size_t k = 1; k < m.images.size(); ++k) {
    MeasurementImage& image = m.images[k];
    // The channel both list that is brightest in both captures: the larger
    // the share of its capture's light a channel receives, the less its
    // albedo is noise (a weak channel, e.g. R under the green LED,
    // registers on its noise).
    auto light_share = [&](const MeasurementImage& im, const std::string& c) {
      double own = 0, brightest = 0;
      for (int k = 0; k < 3; ++k) {
        const double w = (m.camera.rgb[static_cast<std::size_t>(k)] * im.illuminant).values().sum();
        brightest = std::max(brightest, w);
        if (k == channel_index(c)) own = w;
      }
      return brightest > 0 ? own / brightest : 0.0;
    };
    std::string shared;
    double strongest = -1;
    for (const auto& c : image.channels) {
      if (std::find(first.channels.begin(), first.channels.end(), c) == first.channels.end()) continue;
      const double share = std::min(light_share(image, c), light_share(first, c));
      if (share > strongest) strongest = share, shared = c;
    }
    if (shared.empty()) shared = image.channels.front();
    try {
      const RegistrationResult r =
          register_channel(first.pixels.channel(shared), image.pixels.channel(shared), m.width, m.height, options);
      const double motion = corner_displacement_px(r, m.width, m.height);
      const bool warped = motion_is_significant(r, motion);
      if (warped)
        for (auto& channel : image.pixels.channels) channel = warp_channel(channel, m.width, m.height, r);
      out.push_back({image.name, first.name, shared, r, motion, warped});
    } catch (const RegistrationError& e) {
      throw RegistrationError("registering " + image.name + " to " + first.name + ": " + e.what());
    }
  }
  return out;
}

}  // namespace chromo::session
