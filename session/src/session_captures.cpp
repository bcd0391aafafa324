#include "chromo/session/session_captures.hpp"
#include "chromo/files/bounded_read.hpp"

#include "chromo/calibration/led_library_io.hpp"
#include "chromo/spectral/table.hpp"

#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "chromo/session/frame_files.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/session_store.hpp"

namespace chromo::session {

namespace {

std::string mix_key(const std::string& mix) {
  if (mix == "d65" || mix == "w57") return mix;
  if (mix.rfind("w57:", 0) == 0) return "w57";
  if (mix == "w57+blue" || mix.rfind("w57+blue:", 0) == 0) return "w57+blue";
  return {};
}

const char* const kMixes[3] = {"d65", "w57", "w57+blue"};

// The illumination state a lit step's white and subject are paired by:
// the method's mix ("d65", "w57", "w57+blue"; any blue ratio), or the drive
// weights ("weights:0,0,0,0,0,1"). Empty for an unlit step.
std::string state_key(const Illumination& illumination) {
  if (illumination.kind == Illumination::Kind::kMix) return mix_key(illumination.mix);
  if (illumination.kind != Illumination::Kind::kWeights) return {};
  std::string key = "weights:";
  bool lit = false;
  for (std::size_t i = 0; i < illumination.weights.size(); ++i) {
    char text[32];
    std::snprintf(text, sizeof text, "%s%.9g", i ? "," : "", illumination.weights[i]);
    key += text;
    lit = lit || illumination.weights[i] > 0;
  }
  return lit ? key : std::string();
}

// A capture's name in the measurement's channel names: D65', W57, W57+blue
// for the method's mixes, else the subject step's name without "subject_".
std::string capture_name(const std::string& state, const std::string& subject_step) {
  if (state == "d65") return "D65'";
  if (state == "w57") return "W57";
  if (state == "w57+blue") return "W57+blue";
  return subject_step.rfind("subject_", 0) == 0 ? subject_step.substr(8) : subject_step;
}

}  // namespace

SessionCaptureBuilder::SessionCaptureBuilder(const SessionPlan& plan, CaptureSources sources)
    : sources_(std::move(sources)) {
  for (const auto& step : plan.steps) {
    std::string key;
    if (step.role == StepRole::kDark) {
      key = "dark";
    } else {
      const std::string state = state_key(step.illumination);
      if (state.empty())
        throw std::invalid_argument("step " + step.name + ": a " + role_name(step.role) +
                                    " step needs light (a mix or non-zero LED weights) for the estimation");
      key = std::string(step.role == StepRole::kWhite ? "white:" : "subject:") + state;
      if (step.role == StepRole::kSubject) states_.push_back({state, step.name});
    }
    if (steps_.count(key)) throw std::invalid_argument("step " + step.name + ": a second " + key + " step");
    steps_[key] = StepSum{step.name, step.frames_per_camera, {}, {}};
    key_of_step_[step.name] = key;
  }
  std::string missing;
  if (!steps_.count("dark")) missing += " dark";
  if (states_.empty()) missing += " subject (no lit subject step)";
  for (const auto& [state, step] : states_)
    if (!steps_.count("white:" + state)) missing += " white:" + state + " (the white reference of " + step + ")";
  for (const auto& [key, sum] : steps_)
    if (key.rfind("white:", 0) == 0 && !steps_.count("subject:" + key.substr(6)))
      missing += " subject:" + key.substr(6) + " (for " + sum.step + ")";
  if (!missing.empty())
    throw std::invalid_argument("the plan cannot be estimated: no step for" + missing);
  method_plan_ = states_.size() == 3;
  for (const char* mix : kMixes) method_plan_ = method_plan_ && steps_.count(std::string("subject:") + mix);
}

bool SessionCaptureBuilder::add_frame(const FrameRecord& record, std::span<const std::uint8_t> samples) {
  const std::string& step = record.step;
  auto key = key_of_step_.find(step);
  if (key == key_of_step_.end()) throw std::invalid_argument("frame of step \"" + step + "\": not in the plan");
  if (camera_.empty()) camera_ = record.camera;
  if (record.camera != camera_) return false;
  const auto& format = drivers::pixel_format_info(record.pixel_format);
  if (format.layout == drivers::ColourLayout::kMono)
    throw std::invalid_argument("step " + step + ": pixel format \"" + std::string(format.name) +
                                "\" has no colour; the estimator needs BayerRG or RGB8 frames");
  const bool bayer = format.layout == drivers::ColourLayout::kBayerRGGB;
  if (record.width <= 0 || record.height <= 0 || (bayer && (record.width % 2 || record.height % 2)))
    throw std::invalid_argument("step " + step + ": a " + std::to_string(record.width) + "×" +
                                std::to_string(record.height) + " frame (Bayer frames need even sizes)");
  spectral::Spectrum illuminant;
  if (key->second != "dark") {
    if (!record.led)
      throw std::invalid_argument("step " + step + ": the frame's record has no led.drive (the applied LED levels)");
    for (auto type : spectral::kAllLedTypes)
      illuminant += sources_.led_library.led(type).spectrum_per_unit_drive() *
                    record.led->drive[static_cast<std::size_t>(spectral::led_type_index(type))];
  }
  StepSum& s = steps_[key->second];
  if (s.frames.frames() > 0 && record.exposure_us != s.exposure_us)
    throw std::invalid_argument("step " + step + ": a frame at " + std::to_string(record.exposure_us) +
                                " us among frames at " + std::to_string(s.exposure_us) + " us (camera " + camera_ + ")");
  s.frames.add(record, samples);  // checks the size and that the step's frames agree
  s.exposure_us = record.exposure_us;
  s.illuminant_sum += illuminant;
  return true;
}

bool SessionCaptureBuilder::references_complete() const {
  for (const auto& [key, s] : steps_)
    if (key.rfind("subject:", 0) != 0 && s.frames.frames() < s.expected) return false;
  return true;
}

bool SessionCaptureBuilder::complete() const {
  for (const auto& [key, s] : steps_)
    if (s.frames.frames() < s.expected) return false;
  return true;
}

std::string SessionCaptureBuilder::missing() const {
  std::string out;
  for (const auto& [key, s] : steps_)
    if (s.frames.frames() < s.expected)
      out += (out.empty() ? "" : ", ") + s.step + ": " + std::to_string(s.frames.frames()) + " of " +
             std::to_string(s.expected) + " frames";
  return out;
}

RgbImage SessionCaptureBuilder::mean_image(const StepSum& s) const {
  RgbImage image;
  const FrameSums& f = s.frames;
  if (f.frames() == 0) return image;
  const bool bayer = f.format().layout == drivers::ColourLayout::kBayerRGGB;
  image.width = bayer ? f.width() / 2 : f.width(), image.height = bayer ? f.height() / 2 : f.height();
  image.frames = f.frames();
  image.exposure_us = s.exposure_us;
  const auto pixels = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
  for (auto& plane : image.planes) plane.resize(pixels);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const std::size_t o = static_cast<std::size_t>(y) * image.width + x;
      if (bayer) {  // RGGB: R at (even row, even column)
        const std::size_t top = static_cast<std::size_t>(2 * y) * f.width() + 2 * x, bottom = top + f.width();
        image.planes[0][o] = static_cast<float>(f.mean(top));
        image.planes[1][o] = static_cast<float>(0.5 * (f.mean(top + 1) + f.mean(bottom)));
        image.planes[2][o] = static_cast<float>(f.mean(bottom + 1));
      } else {
        for (int c = 0; c < 3; ++c) image.planes[c][o] = static_cast<float>(f.mean(o * 3 + c));
      }
    }
  return image;
}

PlanCaptures SessionCaptureBuilder::plan_captures() const {
  if (!references_complete()) throw std::logic_error("captures: missing " + missing());
  PlanCaptures c;
  c.camera = sources_.camera;
  c.white_reflectance = sources_.white_reflectance;
  c.dark = mean_image(steps_.at("dark"));
  for (const auto& [state, step] : states_) {
    const StepSum& white = steps_.at("white:" + state);
    const StepSum& subject = steps_.at("subject:" + state);
    IlluminatedCapture capture;
    capture.name = capture_name(state, step);
    capture.white = mean_image(white);
    capture.subject = mean_image(subject);
    capture.illuminant = (white.illuminant_sum + subject.illuminant_sum) /
                         static_cast<double>(std::max(1u, white.frames.frames() + subject.frames.frames()));
    c.captures.push_back(std::move(capture));
  }
  return c;
}

MethodCaptures SessionCaptureBuilder::captures() const {
  if (!method_plan_)
    throw std::invalid_argument("the plan is not the method's standard session (subjects under exactly d65, w57 and "
                                "w57+blue); use plan_captures()");
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
                                                                               std::max(1u, white.frames.frames() + subject.frames.frames()));
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
  for_each_stored_frame(
      folder, [&](std::uint64_t index) { return already_added.count(index) == 0; },
      [&](const FrameRecord& record, std::span<const std::uint8_t> samples) {
        if (builder.add_frame(record, samples)) ++added;
      });
  return added;
}

namespace {
SessionCaptureBuilder stored_session_builder(const std::filesystem::path& folder, const CaptureSources& sources) {
  if (!std::filesystem::exists(folder / "journal.jsonl"))
    throw std::invalid_argument(folder.string() + ": not a session folder (no journal.jsonl)");
  SessionCaptureBuilder builder(read_session_plan(folder), sources);
  add_stored_frames(builder, folder);
  if (!builder.complete())
    throw std::invalid_argument(folder.string() + ": the session's frames are incomplete (" + builder.missing() + ")");
  return builder;
}
}  // namespace

MethodCaptures read_session_captures(const std::filesystem::path& folder, const CaptureSources& sources) {
  const SessionCaptureBuilder builder = stored_session_builder(folder, sources);
  if (!builder.is_method_plan())
    throw std::invalid_argument(folder.string() + ": the session's plan is not the method's standard session");
  return builder.captures();
}

StoredSessionCaptures read_any_session_captures(const std::filesystem::path& folder, const CaptureSources& sources) {
  const SessionCaptureBuilder builder = stored_session_builder(folder, sources);
  StoredSessionCaptures out;
  if (builder.is_method_plan()) out.method = builder.captures();
  else out.plan = builder.plan_captures();
  return out;
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
