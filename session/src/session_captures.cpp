#include "chromo/session/session_captures.hpp"
#include "chromo/session/session_provenance.hpp"
#include "chromo/files/bounded_read.hpp"

#include "chromo/calibration/led_library_io.hpp"
#include "chromo/spectral/table.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "chromo/session/frame_files.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/session_store.hpp"

namespace chromo::session {

namespace {

// A white's and its subject's frames together: the capture's illuminant
// (exactly the white's alone where the subject's levels are the same).
spectral::Spectrum both_illuminants(IlluminantMean white, const IlluminantMean& subject) {
  return (white += subject).mean();
}

const char* const kMixes[3] = {"d65", "w57", "w57+blue"};
const char* const kParallelD65 = "d65:parallel";  // illumination_state of a D65' parallel step

// The white reference as the subject's light would have lit it. Both are
// taken under one mix, but the LEDs' junctions are at other temperatures
// for each (the frames record theirs, the library has each LED's flux and
// centroid per kelvin), or the controller applied other levels to the
// subject, so the white's signal above the dark in channel c
// is to be scaled by ∫S_c·E_subject / ∫S_c·E_white (IlluminatedCapture::
// white_signal_scale, applied where the albedo is formed, after the
// white's saturation check). The capture's illuminant is then the white's,
// the light the tables prepared during capture were made for (the albedo
// is the subject's response to its own light, normalised as the model
// normalises the white's: equal for a flat albedo, a second-order
// difference otherwise). Without a difference (no thermal record, or
// records of before per-trigger temperatures), and before the subject's
// frames are in (the references alone), the capture is left as it was.
void put_white_under_subject_light(IlluminatedCapture& capture, const spectral::CameraSensitivity& camera,
                                   const spectral::Spectrum& white_light, const spectral::Spectrum& subject_light) {
  if (!(subject_light.integral() > 0) || !(white_light.integral() > 0)) return;  // no subject frames yet
  bool differs = false;
  std::array<double, 3> scale{1.0, 1.0, 1.0};
  for (int c = 0; c < 3; ++c) {
    const double white_signal = (camera.rgb[c] * white_light).integral();
    scale[c] = white_signal > 0 ? (camera.rgb[c] * subject_light).integral() / white_signal : 1.0;
    differs = differs || scale[c] != 1.0;
  }
  if (!differs) return;
  capture.white_signal_scale = scale;
  capture.illuminant = white_light;
}


}  // namespace

SessionCaptureBuilder::SessionCaptureBuilder(const SessionPlan& plan, CaptureSources sources,
                                             std::shared_ptr<const SessionFrameSums> stored_sums)
    : sources_(std::move(sources)),
      own_sums_(stored_sums ? nullptr : std::make_shared<SessionFrameSums>()),
      sums_(stored_sums ? std::move(stored_sums) : own_sums_),
      reads_stored_sums_(!own_sums_) {
  for (const auto& step : plan.steps) {
    std::string key;
    if (step.role == StepRole::kDark) {
      key = "dark";
    } else {
      const IlluminationState illumination = illumination_state(step);
      const std::string& state = illumination.key;
      if (state.empty())
        throw std::invalid_argument("step " + step.name + ": a " + role_name(step.role) +
                                    " step needs light (a mix or non-zero LED weights) for the estimation");
      key = std::string(!step.linearity_of.empty()   ? "linearity:"
                        : step.role == StepRole::kWhite ? "white:"
                                                        : "subject:") +
            state;
      if (step.role == StepRole::kSubject) states_.push_back({state, capture_name(illumination), step.name});
    }
    if (plan_steps_.count(key)) throw std::invalid_argument("step " + step.name + ": a second " + key + " step");
    plan_steps_[key] = StepSum{step.name, step.frames_per_camera, 0, {}, 0};
    key_of_step_[step.name] = key;
  }
  std::string missing;
  if (!plan_steps_.count("dark")) missing += " dark";
  if (states_.empty()) missing += " subject (no lit subject step)";
  for (const State& state : states_)
    if (!plan_steps_.count("white:" + state.key))
      missing += " white:" + state.key + " (the white reference of " + state.subject_step + ")";
  for (const auto& [key, sum] : plan_steps_)
    if (key.rfind("white:", 0) == 0 && !plan_steps_.count("subject:" + key.substr(6)))
      missing += " subject:" + key.substr(6) + " (for " + sum.step + ")";
  if (!missing.empty())
    throw std::invalid_argument("the plan cannot be estimated: no step for" + missing);
  // The method's three mixes, and on a polarised sphere D65' parallel besides.
  const bool parallel = plan_steps_.count(std::string("subject:") + kParallelD65) > 0;
  standard_plan_ = states_.size() == (parallel ? 4u : 3u);
  for (const char* mix : kMixes) standard_plan_ = standard_plan_ && plan_steps_.count(std::string("subject:") + mix);
}

const std::string& SessionCaptureBuilder::camera() const {
  static const std::string none;
  return cameras_.empty() ? none : cameras_.front();
}

const SessionCaptureBuilder::StepSums& SessionCaptureBuilder::sums_of(const std::string& camera) const {
  const auto found = by_camera_.find(camera);
  return found == by_camera_.end() ? plan_steps_ : found->second;
}

std::pair<SessionCaptureBuilder::StepSum*, spectral::Spectrum> SessionCaptureBuilder::checked_step(
    const FrameRecord& record, StepSums& fresh_camera) {
  const std::string& step = record.step;
  auto key = key_of_step_.find(step);
  if (key == key_of_step_.end()) throw std::invalid_argument("frame of step \"" + step + "\": not in the plan");
  const std::string& camera = record.camera;
  const std::string where = "step " + step + " (camera " + camera + ")";
  const auto& format = drivers::pixel_format_info(record.pixel_format);
  if (format.layout == drivers::ColourLayout::kMono)
    throw std::invalid_argument(where + ": pixel format \"" + std::string(format.name) +
                                "\" has no colour; the estimator needs BayerRG or RGB8 frames");
  const bool bayer = format.layout == drivers::ColourLayout::kBayerRGGB;
  if (record.width <= 0 || record.height <= 0 || (bayer && (record.width % 2 || record.height % 2)))
    throw std::invalid_argument(where + ": a " + std::to_string(record.width) + "×" +
                                std::to_string(record.height) + " frame (Bayer frames need even sizes)");
  spectral::Spectrum illuminant;
  if (key->second != "dark") {
    if (!record.led)
      throw std::invalid_argument(where + ": the frame's record has no led.drive (the applied LED levels)");
    for (auto type : spectral::kAllLedTypes) {
      const auto index = static_cast<std::size_t>(spectral::led_type_index(type));
      const calibration::LedRecord& led = sources_.library_for(record.led->polarisation[index]).led(type);
      // The LED at the temperature it had at this frame's trigger (only
      // records that carry it: the step's first reading is the previous
      // step's junction).
      illuminant += (record.led->temperatures_at_trigger ? led.spectrum_at(record.led->temperature_C[index])
                                                          : led.spectrum_per_unit_drive()) *
                    record.led->drive[index];
    }
  }
  // A camera's first frame goes into a fresh copy of the plan's sums, kept only once the frame is in.
  const auto existing = by_camera_.find(camera);
  if (existing == by_camera_.end()) fresh_camera = plan_steps_;
  StepSum& s = (existing == by_camera_.end() ? fresh_camera : existing->second).at(key->second);
  if (s.frames > 0 && record.exposure_us != s.exposure_us)
    throw std::invalid_argument(where + ": a frame at " + std::to_string(record.exposure_us) + " us among frames at " +
                                std::to_string(s.exposure_us) + " us");
  return {&s, illuminant};
}

void SessionCaptureBuilder::count_frame(const FrameRecord& record, StepSum& s, const spectral::Spectrum& illuminant,
                                        StepSums& fresh_camera) {
  ++s.frames;
  s.exposure_us = record.exposure_us;
  s.illuminant.add(illuminant);
  if (!by_camera_.count(record.camera)) {  // the camera's first frame: its own sums from the plan's
    by_camera_.emplace(record.camera, std::move(fresh_camera));
    cameras_.push_back(record.camera);
  }
}

void SessionCaptureBuilder::add_frame(const FrameRecord& record, std::span<const std::uint8_t> samples) {
  if (reads_stored_sums_) throw std::logic_error("add_frame on a capture builder reading stored sums");
  StepSums fresh_camera;
  auto [s, illuminant] = checked_step(record, fresh_camera);
  own_sums_->add(record, samples);  // checks the size and that the step's frames agree
  count_frame(record, *s, illuminant, fresh_camera);
}

void SessionCaptureBuilder::add_summed_frame(const FrameRecord& record) {
  if (!reads_stored_sums_) throw std::logic_error("add_summed_frame on a capture builder summing its own frames");
  StepSums fresh_camera;
  auto [s, illuminant] = checked_step(record, fresh_camera);
  count_frame(record, *s, illuminant, fresh_camera);
}

bool SessionCaptureBuilder::references_complete(const std::string& camera) const {
  for (const auto& [key, s] : sums_of(camera))  // a linearity white comes after the subjects: not awaited here
    if (key.rfind("subject:", 0) != 0 && key.rfind("linearity:", 0) != 0 && s.frames < s.expected)
      return false;
  return true;
}

bool SessionCaptureBuilder::complete(const std::string& camera) const {
  for (const auto& [key, s] : sums_of(camera))
    if (s.frames < s.expected) return false;
  return true;
}

std::string SessionCaptureBuilder::missing(const std::string& camera) const {
  std::string out;
  for (const auto& [key, s] : sums_of(camera))
    if (s.frames < s.expected)
      out += (out.empty() ? "" : ", ") + s.step + ": " + std::to_string(s.frames) + " of " +
             std::to_string(s.expected) + " frames";
  return out;
}

RgbImage SessionCaptureBuilder::mean_image(const std::string& camera, const StepSum& s) const {
  RgbImage image;
  if (s.frames == 0 || s.frames < s.expected) return image;  // the sum may still grow
  const FrameSums* summed = sums_->find(s.step, camera);
  if (!summed || summed->frames() != s.frames)
    throw std::invalid_argument("step " + s.step + " (camera " + camera + "): its frame sums hold " +
                                std::to_string(summed ? summed->frames() : 0) + " frames, but " +
                                std::to_string(s.frames) + " were counted (a frame the sums refused)");
  const FrameSums& f = *summed;
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

std::optional<RgbImage> SessionCaptureBuilder::linearity_white(const std::string& camera, const StepSums& steps,
                                                              const std::string& state) const {
  const auto found = steps.find("linearity:" + state);
  if (found == steps.end() || found->second.frames < found->second.expected) return std::nullopt;
  return mean_image(camera, found->second);
}

IlluminatedCapture SessionCaptureBuilder::capture_of(const std::string& camera, const StepSums& steps,
                                                    const std::string& state, const std::string& name) const {
  const StepSum& white = steps.at("white:" + state);
  const StepSum& subject = steps.at("subject:" + state);
  IlluminatedCapture capture;
  capture.name = name;
  capture.white = mean_image(camera, white);
  capture.subject = mean_image(camera, subject);
  capture.white_linearity = linearity_white(camera, steps, state);
  // The illuminant as the sphere emitted it for both captures (white and subject).
  capture.illuminant = both_illuminants(white.illuminant, subject.illuminant);
  put_white_under_subject_light(capture, sources_.sensitivity_of(camera).sensitivity, white.illuminant.mean(),
                                subject.illuminant.mean());
  return capture;
}

Captures SessionCaptureBuilder::captures(const std::string& camera) const {
  if (!references_complete(camera)) throw std::logic_error("captures of camera \"" + camera + "\": missing " + missing(camera));
  const StepSums& steps = sums_of(camera);
  Captures c;
  c.camera = sources_.sensitivity_of(camera).sensitivity;
  c.white_reflectance = sources_.white_reflectance;
  c.dark = mean_image(camera, steps.at("dark"));
  if (!standard_plan_) {
    for (const State& state : states_) c.captures.push_back(capture_of(camera, steps, state.key, state.capture_name));
    return c;
  }
  // The standard plan: D65', W57, W57+blue in the recipe's order, and D65' parallel apart.
  for (const char* mix : kMixes) c.captures.push_back(capture_of(camera, steps, mix, capture_name({mix, mix})));
  c.recipe = standard_recipe();
  if (steps.count(std::string("subject:") + kParallelD65)) {
    c.parallel = capture_of(camera, steps, kParallelD65, capture_name({kParallelD65, kParallelD65}));  // "D65' parallel"
    c.surface_factors = sources_.surface_factors;
  }
  return c;
}

std::string SessionCaptureBuilder::sensitivity_source(const std::string& camera) const {
  return sources_.sensitivity_of(camera).source;
}

namespace {

// A session folder's session.json, checked to be an object with a plan of a known format.
nlohmann::json read_session_json(const std::filesystem::path& folder) {
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
  return session;
}

}  // namespace

SessionPlan read_session_plan(const std::filesystem::path& folder) {
  const nlohmann::json session = read_session_json(folder);
  try {
    return plan_from_json(session.at("plan"));
  } catch (const std::exception& error) {
    throw std::invalid_argument((folder / "session.json").string() + ": plan: " + error.what());
  }
}

SessionProvenance read_session_provenance(const std::filesystem::path& folder) {
  const nlohmann::json session = read_session_json(folder);
  if (!session.contains("provenance")) return {};
  try {
    return provenance_from_json(session.at("provenance"));
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument((folder / "session.json").string() + ": " + error.what());
  }
}

std::size_t add_stored_frames(SessionCaptureBuilder& builder, const std::filesystem::path& folder,
                              const std::set<std::uint64_t>& already_added,
                              const std::function<bool(const FrameRecord&)>& wanted,
                              std::map<std::string, std::string>* unusable) {
  std::size_t added = 0;
  auto add = [&](const FrameRecord& record, std::span<const std::uint8_t> samples) {
    if (wanted && !wanted(record)) return;
    try {
      if (builder.reads_stored_sums()) builder.add_summed_frame(record);
      else builder.add_frame(record, samples);
    } catch (const std::invalid_argument& error) {
      if (!unusable) throw;
      unusable->emplace(record.camera, error.what());
      return;
    }
    ++added;
  };
  const auto not_added = [&](std::uint64_t index) { return already_added.count(index) == 0; };
  // A builder reading stored sums has every stored frame's samples summed: the records are enough.
  if (builder.reads_stored_sums()) for_each_stored_record(folder, not_added, [&](const FrameRecord& r) { add(r, {}); });
  else for_each_stored_frame(folder, not_added, add);
  return added;
}

std::function<bool(const FrameRecord&)> first_camera_only() {
  return [camera = std::string()](const FrameRecord& record) mutable {
    if (camera.empty()) camera = record.camera;
    return record.camera == camera;
  };
}

namespace {
SessionCaptureBuilder stored_session_builder(const std::filesystem::path& folder, const CaptureSources& sources) {
  if (!std::filesystem::exists(folder / "journal.jsonl"))
    throw std::invalid_argument(folder.string() + ": not a session folder (no journal.jsonl)");
  SessionCaptureBuilder builder(read_session_plan(folder), sources);
  add_stored_frames(builder, folder, {}, first_camera_only());
  if (!builder.complete())
    throw std::invalid_argument(folder.string() + ": the session's frames are incomplete (" + builder.missing() + ")");
  return builder;
}
}  // namespace

SessionCaptureBuilder read_stored_session(const std::filesystem::path& folder, const CaptureSources& sources,
                                          std::map<std::string, std::string>* unusable) {
  if (!std::filesystem::exists(folder / "journal.jsonl"))
    throw std::invalid_argument(folder.string() + ": not a session folder (no journal.jsonl)");
  SessionCaptureBuilder builder(read_session_plan(folder), sources);
  std::map<std::string, std::string> refused;
  add_stored_frames(builder, folder, {}, {}, &refused);
  // One camera in all: its refused frame is the session's error, as before.
  std::set<std::string> cameras(builder.cameras().begin(), builder.cameras().end());
  for (const auto& [camera, reason] : refused) cameras.insert(camera);
  if (cameras.size() == 1 && !refused.empty()) throw std::invalid_argument(refused.begin()->second);
  if (unusable) *unusable = std::move(refused);
  if (builder.cameras().empty() && cameras.empty())
    throw std::invalid_argument(folder.string() + ": the session stored no frame");
  if (builder.cameras().size() == 1 && !builder.complete())
    throw std::invalid_argument(folder.string() + ": the session's frames are incomplete (" + builder.missing() + ")");
  return builder;
}

Captures read_session_captures(const std::filesystem::path& folder, const CaptureSources& sources) {
  return stored_session_builder(folder, sources).captures();
}

CameraSensitivitySource CaptureSources::sensitivity_of(const std::string& camera_name) const {
  if (auto found = camera_of.find(camera_name); found != camera_of.end()) return found->second;
  return {camera, camera_source};
}

const calibration::LedLibrary& CaptureSources::library_for(drivers::Polarisation state) const {
  if (auto found = led_library_of_state.find(state); found != led_library_of_state.end()) return found->second.library;
  return led_library;
}

std::string session_state_library_file(drivers::Polarisation state) {
  return std::string("led_library-") + drivers::polarisation_name(state) + ".json";
}

std::map<std::string, std::string> state_library_sources(const CaptureSources& sources) {
  std::map<std::string, std::string> out;
  for (const auto& [state, measured] : sources.led_library_of_state) out[drivers::polarisation_name(state)] = measured.source;
  return out;
}

void load_session_state_libraries(const std::filesystem::path& results_folder, CaptureSources& sources) {
  for (auto state : {drivers::Polarisation::kCross, drivers::Polarisation::kParallel}) {
    const std::filesystem::path file = results_folder / session_state_library_file(state);
    if (!std::filesystem::exists(file)) continue;
    try {
      sources.led_library_of_state[state] = {calibration::load_led_library(file), file.string()};
    } catch (const spectral::DataError& error) {
      throw std::invalid_argument(file.string() + ": " + error.what());
    }
  }
}

CaptureSources resolve_capture_sources(const std::string& led_library, const std::string& camera,
                                       double white_reflectance, const std::map<std::string, std::string>& camera_of) {
  CaptureSources sources;
  try {
    const std::filesystem::path path =
        led_library.empty() ? calibration::latest_led_library_path() : std::filesystem::path(led_library);
    if (led_library == kNominalLedLibrary) {
      sources.led_library = calibration::nominal_led_library();
      sources.led_library_source = "nominal (built-in)";
    } else if (path.empty()) {
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
  auto read_sensitivity = [](const std::string& spec, const std::string& what) {
    try {
      return spec.rfind("builtin:", 0) == 0 ? spectral::builtin_camera(spec.substr(8))
                                            : spectral::read_camera_sensitivity(spec);
    } catch (const std::exception& error) {
      throw std::invalid_argument(what + ": " + spec + ": " + error.what());
    }
  };
  sources.camera = read_sensitivity(camera, "estimation.camera_sensitivity");
  sources.camera_source = camera;
  for (const auto& [name, spec] : camera_of)
    sources.camera_of[name] = {read_sensitivity(spec, "estimation.camera_sensitivities[\"" + name + "\"]"), spec};
  if (!(white_reflectance > 0 && white_reflectance <= 1))
    throw std::invalid_argument("estimation.white_reflectance: must be in (0, 1]");
  sources.white_reflectance = white_reflectance;
  return sources;
}

}  // namespace chromo::session
