#include "chromo/session/session_captures.hpp"
#include "chromo/files/bounded_read.hpp"

#include "chromo/calibration/led_library_io.hpp"
#include "chromo/spectral/table.hpp"

#include <cstring>
#include <fstream>
#include <stdexcept>

#include "chromo/session/frame_files.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/session_store.hpp"

namespace chromo::session {

namespace {

std::string mix_key(const std::string& mix) {
  if (mix == "d65" || mix == "w57") return mix;
  if (mix == "w57+blue" || mix.rfind("w57+blue:", 0) == 0) return "w57+blue";
  return {};
}

const char* const kMixes[3] = {"d65", "w57", "w57+blue"};

struct Layout {
  bool bayer = false;
  int samples = 1, bytes = 1;
  double full_scale = 255;
};

Layout layout_of(const std::string& format, const std::string& step) {
  Layout l;
  if (format == "RGB8") {
    l.samples = 3;
  } else if (format.rfind("BayerRG", 0) == 0) {
    l.bayer = true;
  } else {
    throw std::invalid_argument("step " + step + ": pixel format \"" + format +
                                "\" has no colour; the estimator needs BayerRG or RGB8 frames");
  }
  const std::string bits = format.substr(format.find_first_of("0123456789"));
  if (bits == "8") l.bytes = 1, l.full_scale = 255;
  else if (bits == "12") l.bytes = 2, l.full_scale = 4095;
  else if (bits == "16") l.bytes = 2, l.full_scale = 65535;
  else throw std::invalid_argument("step " + step + ": pixel format \"" + format + "\" has an unknown bit depth");
  return l;
}

}  // namespace

SessionCaptureBuilder::SessionCaptureBuilder(const SessionPlan& plan, CaptureSources sources)
    : sources_(std::move(sources)) {
  for (const auto& step : plan.steps) {
    std::string key;
    if (step.role == StepRole::kDark) {
      key = "dark";
    } else {
      if (step.illumination.kind != Illumination::Kind::kMix || mix_key(step.illumination.mix).empty())
        throw std::invalid_argument("step " + step.name +
                                    ": lit by explicit weights or an unknown mix; the method's estimation needs the "
                                    "mixes d65, w57 and w57+blue");
      key = std::string(step.role == StepRole::kWhite ? "white:" : "subject:") + mix_key(step.illumination.mix);
    }
    if (steps_.count(key)) throw std::invalid_argument("step " + step.name + ": a second " + key + " step");
    steps_[key] = StepSum{step.name, step.frames_per_camera, 0, 0, 0, {}, {}};
    key_of_step_[step.name] = key;
  }
  std::string missing;
  for (std::string key : {"dark"}) if (!steps_.count(key)) missing += " dark";
  for (const char* mix : kMixes)
    for (const char* role : {"white:", "subject:"})
      if (!steps_.count(std::string(role) + mix)) missing += std::string(" ") + role + mix;
  if (!missing.empty())
    throw std::invalid_argument("the plan is not the method's standard session: no step for" + missing);
}

bool SessionCaptureBuilder::add_frame(const std::string& step, const std::string& camera, const std::string& pixel_format,
                                      int width, int height, std::span<const std::uint8_t> samples,
                                      const nlohmann::json& led) {
  auto key = key_of_step_.find(step);
  if (key == key_of_step_.end()) throw std::invalid_argument("frame of step \"" + step + "\": not in the plan");
  if (camera_.empty()) camera_ = camera;
  if (camera != camera_) return false;
  const Layout layout = layout_of(pixel_format, step);
  if (width <= 0 || height <= 0 || (layout.bayer && (width % 2 || height % 2)))
    throw std::invalid_argument("step " + step + ": a " + std::to_string(width) + "×" + std::to_string(height) +
                                " frame (Bayer frames need even sizes)");
  const std::size_t expected_bytes = static_cast<std::size_t>(width) * height * layout.samples * layout.bytes;
  if (samples.size() != expected_bytes)
    throw std::invalid_argument("step " + step + ": frame has " + std::to_string(samples.size()) + " bytes, " +
                                std::to_string(expected_bytes) + " expected for " + pixel_format);
  StepSum& s = steps_[key->second];
  const int out_width = layout.bayer ? width / 2 : width, out_height = layout.bayer ? height / 2 : height;
  if (s.frames == 0) {
    s.width = out_width, s.height = out_height;
    for (auto& plane : s.sum) plane.assign(static_cast<std::size_t>(out_width) * out_height, 0.0);
  } else if (s.width != out_width || s.height != out_height) {
    throw std::invalid_argument("step " + step + ": frames of one step differ in size");
  }
  auto sample = [&](std::size_t index) -> double {
    if (layout.bytes == 1) return samples[index];
    std::uint16_t v;
    std::memcpy(&v, &samples[index * 2], 2);
    return v;
  };
  const double scale = 1.0 / layout.full_scale;
  for (int y = 0; y < out_height; ++y)
    for (int x = 0; x < out_width; ++x) {
      const std::size_t o = static_cast<std::size_t>(y) * out_width + x;
      if (layout.bayer) {  // RGGB: R at (even row, even column)
        const std::size_t top = static_cast<std::size_t>(2 * y) * width + 2 * x, bottom = top + width;
        s.sum[0][o] += sample(top) * scale;
        s.sum[1][o] += 0.5 * (sample(top + 1) + sample(bottom)) * scale;
        s.sum[2][o] += sample(bottom + 1) * scale;
      } else {
        for (int c = 0; c < 3; ++c) s.sum[c][o] += sample(o * 3 + c) * scale;
      }
    }
  spectral::Spectrum illuminant;
  if (key->second != "dark") {
    if (!led.contains("drive") || !led["drive"].is_object())
      throw std::invalid_argument("step " + step + ": the frame's record has no led.drive (the applied LED levels)");
    for (const auto& [name, level] : led["drive"].items()) {
      auto type = spectral::parse_led_type(name);
      if (!type || !level.is_number())
        throw std::invalid_argument("step " + step + ": led.drive." + name + " is not an LED type with a level");
      illuminant += sources_.led_library.led(*type).spectrum_per_unit_drive() * level.get<double>();
    }
  }
  s.illuminant_sum += illuminant;
  ++s.frames;
  return true;
}

bool SessionCaptureBuilder::references_complete() const {
  for (const auto& [key, s] : steps_)
    if (key.rfind("subject:", 0) != 0 && s.frames < s.expected) return false;
  return true;
}

bool SessionCaptureBuilder::complete() const {
  for (const auto& [key, s] : steps_)
    if (s.frames < s.expected) return false;
  return true;
}

std::string SessionCaptureBuilder::missing() const {
  std::string out;
  for (const auto& [key, s] : steps_)
    if (s.frames < s.expected)
      out += (out.empty() ? "" : ", ") + s.step + ": " + std::to_string(s.frames) + " of " +
             std::to_string(s.expected) + " frames";
  return out;
}

RgbImage SessionCaptureBuilder::mean_image(const StepSum& s) const {
  RgbImage image;
  if (s.frames == 0) return image;
  image.width = s.width, image.height = s.height;
  for (int c = 0; c < 3; ++c) {
    image.planes[c].resize(s.sum[c].size());
    for (std::size_t i = 0; i < s.sum[c].size(); ++i)
      image.planes[c][i] = static_cast<float>(s.sum[c][i] / s.frames);
  }
  return image;
}

spectral::Spectrum SessionCaptureBuilder::mean_illuminant(const StepSum& s) const {
  return s.frames ? s.illuminant_sum / static_cast<double>(s.frames) : s.illuminant_sum;
}

MethodCaptures SessionCaptureBuilder::captures() const {
  if (!references_complete()) throw std::logic_error("captures: missing " + missing());
  MethodCaptures c;
  c.camera = sources_.camera;
  c.white_reflectance = sources_.white_reflectance;
  c.dark = mean_image(steps_.at("dark"));
  const std::pair<IlluminatedCapture*, const char*> targets[] = {
      {&c.broadband, "d65"}, {&c.base, "w57"}, {&c.with_blue, "w57+blue"}};
  for (const auto& [target, mix] : targets) {
    const StepSum& white = steps_.at(std::string("white:") + mix);
    const StepSum& subject = steps_.at(std::string("subject:") + mix);
    target->name = std::string(mix) == "d65" ? "D65'" : std::string(mix) == "w57" ? "W57" : "W57+blue";
    target->white = mean_image(white);
    target->subject = mean_image(subject);
    // The illuminant as the sphere emitted it for both captures (white and subject).
    target->illuminant = (white.illuminant_sum + subject.illuminant_sum) / static_cast<double>(
                                                                               std::max(1u, white.frames + subject.frames));
  }
  return c;
}

SessionPlan read_session_plan(const std::filesystem::path& folder) {
  std::string text;
  try {
    text = files::read_text_file(folder / "session.json", "JSON");
  } catch (const files::InputFileError& e) {
    throw std::invalid_argument(folder.string() + ": not a session folder (" + e.what() + ")");
  }
  auto session = nlohmann::json::parse(text, nullptr, false);
  if (session.is_discarded() || !session.is_object() || !session.contains("plan"))
    throw std::invalid_argument((folder / "session.json").string() + ": not valid JSON with a \"plan\"");
  session_format_version(session, folder / "session.json");
  try {
    return plan_from_json(session.at("plan"));
  } catch (const std::exception& error) {
    throw std::invalid_argument((folder / "session.json").string() + ": plan: " + error.what());
  }
}

std::size_t add_stored_frames(SessionCaptureBuilder& builder, const std::filesystem::path& folder,
                              const std::set<std::uint64_t>& already_added) {
  std::size_t added = 0;
  for (const auto& record : read_journal(folder / "journal.jsonl").records) {
    if (record.value("type", "") != "frame") continue;
    const std::uint64_t index = record.value("index", std::uint64_t{0});
    if (already_added.count(index)) continue;
    const std::string file = record.value("file", "");
    TiffImage image;
    try {
      image = read_tiff(folder / file);
    } catch (const std::exception& error) {
      throw std::invalid_argument((folder / file).string() + ": " + error.what());
    }
    if (builder.add_frame(record.value("step", ""), record.value("camera", ""), record.value("pixel_format", ""),
                          image.width, image.height, image.data, record.value("led", nlohmann::json::object())))
      ++added;
  }
  return added;
}

MethodCaptures read_session_captures(const std::filesystem::path& folder, const CaptureSources& sources) {
  if (!std::filesystem::exists(folder / "journal.jsonl"))
    throw std::invalid_argument(folder.string() + ": not a session folder (no journal.jsonl)");
  SessionCaptureBuilder builder(read_session_plan(folder), sources);
  add_stored_frames(builder, folder);
  if (!builder.complete())
    throw std::invalid_argument(folder.string() + ": the session's frames are incomplete (" + builder.missing() + ")");
  return builder.captures();
}

CaptureSources resolve_capture_sources(const std::string& led_library, const std::string& camera,
                                       double white_reflectance) {
  CaptureSources sources;
  try {
    std::filesystem::path path = led_library;
    if (path.empty()) path = calibration::latest_led_library_path();
    if (path.empty()) {
      sources.led_library = calibration::nominal_led_library();
      sources.led_library_source = "nominal (built-in; no measured library in " +
                                   calibration::led_library_directory().string() + ")";
    } else {
      sources.led_library = calibration::load_led_library(path);
      sources.led_library_source = path.string();
    }
  } catch (const spectral::DataError& error) {
    throw std::invalid_argument(std::string("estimation.led_library: ") + error.what());
  }
  try {
    sources.camera = camera.rfind("builtin:", 0) == 0 ? spectral::builtin_camera(camera.substr(8))
                                                      : spectral::read_camera_sensitivity(camera);
  } catch (const std::exception& error) {
    throw std::invalid_argument("estimation.camera_sensitivity: " + camera + ": " + error.what());
  }
  sources.camera_source = camera;
  if (!(white_reflectance > 0 && white_reflectance <= 1))
    throw std::invalid_argument("estimation.white_reflectance: must be in (0, 1]");
  sources.white_reflectance = white_reflectance;
  return sources;
}

}  // namespace chromo::session
