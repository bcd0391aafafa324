#include "chromo/session/session_plan.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <set>
#include <stdexcept>

#include "chromo/files/bounded_read.hpp"

namespace chromo::session {

std::string control_character_error(const std::string& text, bool multiline) {
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    const bool c1 = c == 0xc2 && i + 1 < text.size() && static_cast<unsigned char>(text[i + 1]) >= 0x80 &&
                    static_cast<unsigned char>(text[i + 1]) <= 0x9f;
    if ((c < 0x20 && !(multiline && (c == '\n' || c == '\t'))) || c == 0x7f || c1) {
      static const char* digits = "0123456789abcdef";
      const unsigned code = c1 ? static_cast<unsigned char>(text[i + 1]) : c;
      return std::string("holds the control character 0x") + digits[code >> 4] + digits[code & 15] + " at byte " +
             std::to_string(i) + " (printed text only)";
    }
  }
  return {};
}

bool is_valid_name(const std::string& name) {
  if (name.empty() || name.size() > kMaxNameBytes) return false;
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '+' || c == '.' || c == '-')) return false;
  return name != "." && name != "..";
}

namespace {
IlluminationState unpolarised_illumination_state(const Step& step);
}  // namespace

IlluminationState illumination_state(const Step& step) {
  IlluminationState state = unpolarised_illumination_state(step);
  if (!state.key.empty() && step.polarisation == drivers::Polarisation::kParallel) {
    state.key += ":parallel";
    state.name += " parallel";
  }
  return state;
}

std::optional<drivers::Polarisation> parse_polarisation(const std::string& text) {
  for (drivers::Polarisation polarisation :
       {drivers::Polarisation::kUnpolarised, drivers::Polarisation::kCross, drivers::Polarisation::kParallel})
    if (text == drivers::polarisation_name(polarisation)) return polarisation;
  return std::nullopt;
}

namespace {
IlluminationState unpolarised_illumination_state(const Step& step) {
  const Illumination& illumination = step.illumination;
  IlluminationState state;
  if (illumination.kind == Illumination::Kind::kMix) {
    state.key = illumination.mix.substr(0, illumination.mix.find(':'));
    state.name = state.key;
    return state;
  }
  if (illumination.kind != Illumination::Kind::kWeights) return state;
  std::string key = "weights:";
  bool lit = false;
  for (std::size_t i = 0; i < illumination.weights.size(); ++i) {
    char text[32];
    std::snprintf(text, sizeof text, "%s%.9g", i ? "," : "", illumination.weights[i]);
    key += text;
    lit = lit || illumination.weights[i] > 0;
  }
  if (!lit) return state;
  state.key = key;
  state.name = step.name;
  for (const char* prefix : {"subject_", "white_"})
    if (step.name.starts_with(prefix) && step.name.size() > std::strlen(prefix)) state.name = step.name.substr(std::strlen(prefix));
  return state;
}
}  // namespace

std::string capture_name(const IlluminationState& state) {
  if (state.key == "d65") return "D65'";
  if (state.key == "w57") return "W57";
  if (state.key == "w57+blue") return "W57+blue";
  if (state.key == "d65:parallel") return "D65' parallel";
  return state.name;
}

bool is_valid_mix(const std::string& mix) {
  if (mix == "d65" || mix == "w57" || mix == "w57+blue") return true;
  const std::string prefix = mix.rfind("w57:", 0) == 0 ? "w57:" : "w57+blue:";
  if (mix.rfind(prefix, 0) != 0 || mix.size() > prefix.size() + 16) return false;
  try {
    std::size_t used = 0;
    double ratio = std::stod(mix.substr(prefix.size()), &used);
    return used == mix.size() - prefix.size() && std::isfinite(ratio) && ratio > 0 && ratio <= 100;
  } catch (const std::exception&) {
    return false;
  }
}

bool SessionPlan::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!is_valid_name(name)) return fail("name: must match [A-Za-z0-9_+.-]{1,64}, got \"" + name.substr(0, 80) + "\"");
  if (steps.empty() || steps.size() > kMaxSteps)
    return fail("steps: must hold 1 to " + std::to_string(kMaxSteps) + " steps, got " + std::to_string(steps.size()));
  std::set<std::string> names;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const Step& step = steps[i];
    const std::string field = "steps[" + std::to_string(i) + "].";
    if (!is_valid_name(step.name)) return fail(field + "name: must match [A-Za-z0-9_+.-]{1,64}");
    if (!names.insert(step.name).second) return fail(field + "name: \"" + step.name + "\" is used twice");
    if (!(step.exposure_us >= kMinExposureUs && step.exposure_us <= kMaxExposureUs))
      return fail(field + "exposure_us: must be in [1, 10000000], got " + nlohmann::json(step.exposure_us).dump());
    if (step.frames_per_camera < 1 || step.frames_per_camera > kMaxFramesPerCamera)
      return fail(field + "frames_per_camera: must be in [1, 1000], got " + std::to_string(step.frames_per_camera));
    if (step.settle_ms > kMaxSettleMs)
      return fail(field + "settle_ms: must be at most 60000, got " + std::to_string(step.settle_ms));
    if (step.prompt.size() > kMaxTextBytes) return fail(field + "prompt: longer than 4096 bytes");
    if (auto bad = control_character_error(step.prompt, true); !bad.empty()) return fail(field + "prompt: " + bad);
    if (step.illumination.kind == Illumination::Kind::kWeights) {
      for (int led = 0; led < drivers::kLedTypeCount; ++led) {
        double level = step.illumination.weights[static_cast<std::size_t>(led)];
        if (!(level >= 0 && level <= 1))
          return fail(field + "weights." +
                      std::string(spectral::led_type_name(static_cast<drivers::LedType>(led))) +
                      ": must be in [0, 1], got " + std::to_string(level));
      }
    } else if (step.illumination.kind == Illumination::Kind::kMix && !is_valid_mix(step.illumination.mix)) {
      return fail(field + "mix: must be d65, w57, w57+blue, w57+blue:R or w57:R with R in (0, 100], got \"" +
                  step.illumination.mix.substr(0, 80) + "\"");
    }
    if (static_cast<int>(step.polarisation) >= drivers::kPolarisationCodeCount)
      return fail(field + "polarisation: unknown code " + std::to_string(static_cast<int>(step.polarisation)));
    if (!illumination_state(step).key.empty() && step.polarisation != drivers::Polarisation::kParallel)
      for (std::size_t j = 0; j < i; ++j)
        if (!illumination_state(steps[j]).key.empty() && steps[j].polarisation != drivers::Polarisation::kParallel &&
            steps[j].polarisation != step.polarisation)
          return fail(field + "polarisation: " + drivers::polarisation_name(step.polarisation) + ", but steps[" +
                      std::to_string(j) + "] is " + drivers::polarisation_name(steps[j].polarisation) +
                      ": a plan's lit steps are either cross or unpolarised (parallel steps may join either)");
    if (!(step.meter_white_share >= 0 && step.meter_white_share <= 1))
      return fail(field + "meter_white_share: must be in (0, 1] (0: not metered), got " +
                  std::to_string(step.meter_white_share));
    if (step.meter_white_share > 0) {
      if (step.role != StepRole::kWhite || step.illumination.kind == Illumination::Kind::kDark)
        return fail(field + "meter_white_share: only a lit white step is metered (the white target is what is metered)");
      if (!step.exposure_from.empty()) return fail(field + "exposure_from: a metered step meters its own exposure");
    }
    // Whether an earlier step is named `name` and does what `is` asks.
    auto earlier = [&](const std::string& name, auto is) {
      for (std::size_t j = 0; j < i; ++j)
        if (steps[j].name == name && is(steps[j])) return true;
      return false;
    };
    if (!step.exposure_from.empty() && !earlier(step.exposure_from, [](const Step& s) { return s.meter_white_share > 0; }))
      return fail(field + "exposure_from: \"" + step.exposure_from.substr(0, 80) +
                  "\" is not an earlier metered white step");
    if (!(step.subject_fill >= 0 && step.subject_fill < 1))
      return fail(field + "subject_fill: must be in (0, 1) (0: not metered), got " + std::to_string(step.subject_fill));
    if (!(step.subject_percentile > 0 && step.subject_percentile <= 1))
      return fail(field + "subject_percentile: must be in (0, 1], got " + std::to_string(step.subject_percentile));
    if (!(step.max_subject_exposure_ratio >= 1 && step.max_subject_exposure_ratio <= 64))
      return fail(field + "max_subject_exposure_ratio: must be in [1, 64], got " +
                  std::to_string(step.max_subject_exposure_ratio));
    if (step.subject_metered()) {
      if (step.role != StepRole::kSubject || step.exposure_from.empty())
        return fail(field + "subject_fill: only a subject step that takes its white's metered exposure (exposure_from) "
                            "is subject-metered");
      if (step.subject_fill > 0 && !step.subject_ratio_from.empty())
        return fail(field + "subject_ratio_from: a subject-metered step meters its own ratio");
    }
    if (!step.subject_ratio_from.empty() &&
        !earlier(step.subject_ratio_from, [](const Step& s) { return s.subject_fill > 0; }))
      return fail(field + "subject_ratio_from: \"" + step.subject_ratio_from.substr(0, 80) +
                  "\" is not an earlier subject-metered step");
    if (!step.linearity_of.empty()) {
      if (step.role != StepRole::kWhite || step.illumination.kind == Illumination::Kind::kDark ||
          step.meter_white_share > 0 || !step.exposure_from.empty())
        return fail(field + "linearity_of: only a lit white step without its own metering (meter_white_share, "
                            "exposure_from) takes a subject's white at the second exposure");
      if (!earlier(step.linearity_of, [](const Step& s) { return s.subject_metered(); }))
        return fail(field + "linearity_of: \"" + step.linearity_of.substr(0, 80) +
                    "\" is not an earlier subject-metered step");
    }
    if (step.metered() && timing == Timing::kHardware)
      return fail(field + "meter_white_share: exposure metering needs software timing (a hardware-timed plan arms "
                          "every state before the first frame)");
  }
  return true;
}

std::uint64_t SessionPlan::frames_per_camera_total() const {
  std::uint64_t total = 0;
  for (const auto& step : steps) total += step.frames_per_camera;
  return total;
}

namespace {

// A built-in plan's step: the options' settle, exposure and frames; the
// operator prompt only when prompts are on.
Step built_in_step(const StandardPlanOptions& options, std::string name, StepRole role, Illumination illumination,
                   std::string prompt) {
  Step s;
  s.name = std::move(name);
  s.role = role;
  s.illumination = std::move(illumination);
  s.settle_ms = options.settle_ms;
  s.exposure_us = options.exposure_us;
  const bool reference = role == StepRole::kDark || role == StepRole::kWhite;
  s.frames_per_camera =
      reference && options.reference_frames > 0 ? options.reference_frames : options.frames_per_camera;
  if (options.operator_prompts) s.prompt = std::move(prompt);
  return s;
}

}  // namespace

SessionPlan standard_plan(const StandardPlanOptions& options) {
  SessionPlan plan;
  plan.name = "standard";
  plan.timing = options.timing;
  const bool metered = options.meter_white_share > 0;
  auto step = [&](std::string name, StepRole role, Illumination illumination, std::string prompt = {},
                  std::string exposure_from = {}) {
    Step s = built_in_step(options, std::move(name), role, std::move(illumination), std::move(prompt));
    if (metered && !exposure_from.empty()) {
      if (exposure_from == s.name) s.meter_white_share = options.meter_white_share;
      else s.exposure_from = std::move(exposure_from);
    }
    plan.steps.push_back(std::move(s));
  };
  auto mix = [](std::string name) {
    Illumination illumination;
    illumination.kind = Illumination::Kind::kMix;
    illumination.mix = std::move(name);
    return illumination;
  };
  char ratio[32] = "";
  if (options.blue_ratio > 0) std::snprintf(ratio, sizeof ratio, ":%g", options.blue_ratio);
  const std::string w57 = std::string("w57") + ratio, w57_blue = std::string("w57+blue") + ratio;
  step("dark", StepRole::kDark, Illumination{}, "Close the sphere (dark frame)");
  step("white_d65", StepRole::kWhite, mix("d65"), "Place the white reference target", "white_d65");
  if (metered) {  // W57 takes the exposure metered under W57+blue: one exposure for the blue-only difference
    step("white_w57+blue", StepRole::kWhite, mix(w57_blue), {}, "white_w57+blue");
    step("white_w57", StepRole::kWhite, mix(w57), {}, "white_w57+blue");
  } else {
    step("white_w57", StepRole::kWhite, mix(w57));
    step("white_w57+blue", StepRole::kWhite, mix(w57_blue));
  }
  const bool subject_metered = metered && options.subject_fill > 0;
  step("subject_d65", StepRole::kSubject, mix("d65"), "Place the subject", "white_d65");
  if (subject_metered) {  // W57 takes the ratio metered on the subject under W57+blue (brighter in B)
    step("subject_w57+blue", StepRole::kSubject, mix(w57_blue), {}, "white_w57+blue");
    step("subject_w57", StepRole::kSubject, mix(w57), {}, "white_w57+blue");
    for (Step& s : plan.steps) {
      if (s.role != StepRole::kSubject) continue;
      if (s.name == "subject_w57") {
        s.subject_ratio_from = "subject_w57+blue";
        continue;
      }
      s.subject_fill = options.subject_fill;
      s.subject_percentile = options.subject_percentile;
      s.max_subject_exposure_ratio = options.max_subject_exposure_ratio;
    }
  } else {
    step("subject_w57", StepRole::kSubject, mix(w57), {}, "white_w57+blue");
    step("subject_w57+blue", StepRole::kSubject, mix(w57_blue), {}, "white_w57+blue");
  }
  if (options.polarised) {
    for (Step& s : plan.steps)
      if (s.role != StepRole::kDark) s.polarisation = drivers::Polarisation::kCross;
    // One parallel capture of the broadband light (parallel − cross is the
    // surface layer): its white after the other whites, its subject right
    // after the cross D65' subject, so the subject barely moves between the two.
    auto parallel_d65 = [&](std::string name, StepRole role, std::string exposure_from) {
      Step s = built_in_step(options, std::move(name), role, mix("d65"), {});
      if (metered && exposure_from == s.name) s.meter_white_share = options.meter_white_share;
      else if (metered) s.exposure_from = std::move(exposure_from);
      s.polarisation = drivers::Polarisation::kParallel;
      return s;
    };
    auto after = [&](const std::string& name) {
      for (std::size_t i = 0; i < plan.steps.size(); ++i)
        if (plan.steps[i].name == name) return plan.steps.begin() + static_cast<std::ptrdiff_t>(i) + 1;
      return plan.steps.end();
    };
    std::string last_white;
    for (const Step& s : plan.steps)
      if (s.role == StepRole::kWhite) last_white = s.name;
    plan.steps.insert(after(last_white), parallel_d65("white_d65_parallel", StepRole::kWhite, "white_d65_parallel"));
    plan.steps.insert(after("subject_d65"), parallel_d65("subject_d65_parallel", StepRole::kSubject, "white_d65_parallel"));
  }
  if (subject_metered) {  // the linearity check's whites, at each white's exposure ÷ g
    const std::pair<const char*, std::string> subjects[] = {
        {"d65", "d65"}, {"w57+blue", w57_blue}, {"w57", w57}};
    for (const auto& [name, illumination] : subjects) {
      Step s = built_in_step(options, std::string("white_") + name + "_linearity", StepRole::kWhite, mix(illumination),
                             name == std::string("d65") ? "Place the white reference target (linearity check)" : "");
      s.linearity_of = std::string("subject_") + name;
      if (options.polarised) s.polarisation = drivers::Polarisation::kCross;
      plan.steps.push_back(std::move(s));
    }
  }
  return plan;
}

std::string role_name(StepRole role) {
  switch (role) {
    case StepRole::kDark: return "dark";
    case StepRole::kWhite: return "white";
    case StepRole::kSubject: return "subject";
  }
  return "subject";
}

std::string timing_name(Timing timing) { return timing == Timing::kHardware ? "hardware" : "software"; }

nlohmann::json drive_levels_to_json(const drivers::DriveLevels& levels) {
  nlohmann::json weights = nlohmann::json::object();
  for (auto type : spectral::kAllLedTypes)
    weights[std::string(spectral::led_type_name(type))] = levels[static_cast<std::size_t>(spectral::led_type_index(type))];
  return weights;
}

drivers::DriveLevels drive_levels_from_json(const nlohmann::json& weights) {
  drivers::DriveLevels levels{};
  for (auto type : spectral::kAllLedTypes)
    levels[static_cast<std::size_t>(spectral::led_type_index(type))] =
        weights.value(std::string(spectral::led_type_name(type)), 0.0);
  return levels;
}

nlohmann::json to_json(const SessionPlan& plan) {
  nlohmann::json steps = nlohmann::json::array();
  for (const auto& step : plan.steps) {
    nlohmann::json s{{"name", step.name},
                     {"role", role_name(step.role)},
                     {"settle_ms", step.settle_ms},
                     {"exposure_us", step.exposure_us},
                     {"frames_per_camera", step.frames_per_camera}};
    if (!step.prompt.empty()) s["prompt"] = step.prompt;
    if (step.meter_white_share > 0) s["meter_white_share"] = step.meter_white_share;
    if (!step.exposure_from.empty()) s["exposure_from"] = step.exposure_from;
    if (step.subject_fill > 0) {
      s["subject_fill"] = step.subject_fill;
      s["subject_percentile"] = step.subject_percentile;
      s["max_subject_exposure_ratio"] = step.max_subject_exposure_ratio;
    }
    if (!step.subject_ratio_from.empty()) s["subject_ratio_from"] = step.subject_ratio_from;
    if (!step.linearity_of.empty()) s["linearity_of"] = step.linearity_of;
    if (step.polarisation != drivers::Polarisation::kUnpolarised)
      s["polarisation"] = drivers::polarisation_name(step.polarisation);
    switch (step.illumination.kind) {
      case Illumination::Kind::kDark: s["illumination"] = {{"dark", true}}; break;
      case Illumination::Kind::kMix: s["illumination"] = {{"mix", step.illumination.mix}}; break;
      case Illumination::Kind::kWeights: {
        s["illumination"] = {{"weights", drive_levels_to_json(step.illumination.weights)}};
        break;
      }
    }
    steps.push_back(std::move(s));
  }
  return {{"name", plan.name}, {"timing", timing_name(plan.timing)}, {"steps", steps}};
}

namespace {
// A count (milliseconds, frames) from a plan: a whole number in [0, 2^32 − 1],
// `fallback` when absent. nlohmann's get<std::uint32_t>() of 7.8e20 is
// undefined behaviour (found by fuzz_session_plan), so the value is checked
// first.
std::uint32_t read_count(const nlohmann::json& step, const char* key, std::uint32_t fallback) {
  if (!step.contains(key)) return fallback;
  const nlohmann::json& value = step.at(key);
  if (value.is_number_unsigned() && value.get<std::uint64_t>() <= 0xFFFFFFFFull)
    return static_cast<std::uint32_t>(value.get<std::uint64_t>());
  throw std::invalid_argument(std::string("session plan: ") + key + ": " + value.dump().substr(0, 64) +
                              " is not a whole number in [0, 4294967295]");
}
}  // namespace

SessionPlan plan_from_json(const nlohmann::json& json) {
  try {
    SessionPlan plan;
    plan.name = json.at("name").get<std::string>();
    plan.timing = json.value("timing", "software") == "hardware" ? Timing::kHardware : Timing::kSoftware;
    for (const auto& s : json.at("steps")) {
      Step step;
      step.name = s.at("name").get<std::string>();
      std::string role = s.value("role", "subject");
      step.role = role == "dark" ? StepRole::kDark : role == "white" ? StepRole::kWhite : StepRole::kSubject;
      step.settle_ms = read_count(s, "settle_ms", 0);
      step.exposure_us = s.at("exposure_us").get<double>();
      step.frames_per_camera = read_count(s, "frames_per_camera", 1);
      step.prompt = s.value("prompt", "");
      if (s.contains("meter_white_share")) {
        const auto& share = s.at("meter_white_share");
        if (!share.is_number() || !std::isfinite(share.get<double>()))
          throw std::invalid_argument("session plan: meter_white_share: " + share.dump().substr(0, 64) + " is not a number");
        step.meter_white_share = share.get<double>();
      }
      step.exposure_from = s.value("exposure_from", "");
      for (auto [key, value] : {std::pair<const char*, double*>{"subject_fill", &step.subject_fill},
                                {"subject_percentile", &step.subject_percentile},
                                {"max_subject_exposure_ratio", &step.max_subject_exposure_ratio}}) {
        if (!s.contains(key)) continue;
        const auto& number = s.at(key);
        if (!number.is_number() || !std::isfinite(number.get<double>()))
          throw std::invalid_argument(std::string("session plan: ") + key + ": " + number.dump().substr(0, 64) +
                                      " is not a number");
        *value = number.get<double>();
      }
      step.subject_ratio_from = s.value("subject_ratio_from", "");
      step.linearity_of = s.value("linearity_of", "");
      if (s.contains("polarisation")) {
        const std::string text = s.at("polarisation").get<std::string>();
        const std::optional<drivers::Polarisation> polarisation = parse_polarisation(text);
        if (!polarisation)
          throw std::invalid_argument("session plan: steps[" + std::to_string(plan.steps.size()) +
                                      "].polarisation: \"" + text.substr(0, 64) +
                                      "\" is not unpolarised, cross or parallel");
        step.polarisation = *polarisation;
      }
      const auto& illumination = s.at("illumination");
      if (illumination.contains("mix")) {
        step.illumination.kind = Illumination::Kind::kMix;
        step.illumination.mix = illumination.at("mix").get<std::string>();
      } else if (illumination.contains("weights")) {
        step.illumination.kind = Illumination::Kind::kWeights;
        step.illumination.weights = drive_levels_from_json(illumination.at("weights"));
      }
      plan.steps.push_back(std::move(step));
    }
    return plan;
  } catch (const nlohmann::json::exception& error) {
    throw std::invalid_argument(std::string("session plan: ") + error.what());
  }
}

}  // namespace chromo::session

namespace chromo::session {

SessionPlan multispectral_plan(const StandardPlanOptions& options, bool with_method_states) {
  SessionPlan plan;
  plan.name = with_method_states ? "multispectral+method" : "multispectral";
  plan.timing = options.timing;
  auto step = [&](std::string name, StepRole role, Illumination illumination, std::string prompt = {}) {
    plan.steps.push_back(built_in_step(options, std::move(name), role, std::move(illumination), std::move(prompt)));
  };
  // The illumination states, in capture order.
  std::vector<std::pair<std::string, Illumination>> states;
  for (auto type : spectral::kAllLedTypes) {
    Illumination alone;
    alone.kind = Illumination::Kind::kWeights;
    alone.weights[static_cast<std::size_t>(spectral::led_type_index(type))] = 1.0;
    states.emplace_back(std::string(spectral::led_type_name(type)), alone);
  }
  if (with_method_states)
    for (const char* mix : {"d65", "w57", "w57+blue"}) {
      Illumination m;
      m.kind = Illumination::Kind::kMix;
      m.mix = mix;
      states.emplace_back(mix, m);
    }
  step("dark", StepRole::kDark, Illumination{}, "Close the sphere (dark frame)");
  for (std::size_t i = 0; i < states.size(); ++i)
    step("white_" + states[i].first, StepRole::kWhite, states[i].second, i == 0 ? "Place the white reference target" : "");
  for (std::size_t i = 0; i < states.size(); ++i)
    step("subject_" + states[i].first, StepRole::kSubject, states[i].second, i == 0 ? "Place the subject" : "");
  return plan;
}

std::vector<std::string> builtin_plan_names() { return {"standard", "multispectral", "multispectral+method"}; }

std::optional<SessionPlan> builtin_plan(const std::string& name, const StandardPlanOptions& options) {
  if (name == "standard") return standard_plan(options);
  if (name == "multispectral") return multispectral_plan(options, false);
  if (name == "multispectral+method") return multispectral_plan(options, true);
  return std::nullopt;
}

PlanTiming plan_timing(const SessionPlan& plan) {
  PlanTiming t;
  bool d65 = false, w57 = false, w57_blue = false;
  for (const Step& step : plan.steps) {
    const double seconds = step.settle_ms / 1000.0 + step.exposure_us * 1e-6 * step.frames_per_camera;
    t.frames_per_camera += step.frames_per_camera;
    if (step.role != StepRole::kSubject) {
      t.reference_time_s += seconds;
      continue;
    }
    t.subject_time_s += seconds;
    ++t.captures;
    if (step.illumination.kind == Illumination::Kind::kMix) {
      d65 = d65 || step.illumination.mix == "d65";
      w57 = w57 || step.illumination.mix == "w57";
      w57_blue = w57_blue || step.illumination.mix.rfind("w57+blue", 0) == 0;
    }
  }
  // The method's session (subjects under exactly d65, w57, w57+blue) gives the
  // method's four channels; any other plan R, G, B per capture.
  t.channels = t.captures == 3 && d65 && w57 && w57_blue ? 4 : 3 * t.captures;
  return t;
}

namespace {

// Fields plan_from_json would read leniently, checked strictly for a file an
// operator wrote: an unknown LED name in weights, a role other than the three.
void check_plan_json(const nlohmann::json& plan) {
  if (!plan.is_object()) throw std::invalid_argument("plan: not a JSON object");
  if (!plan.contains("steps") || !plan.at("steps").is_array()) throw std::invalid_argument("steps: missing or not a list");
  const auto& steps = plan.at("steps");
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const std::string field = "steps[" + std::to_string(i) + "].";
    const auto& s = steps[i];
    if (!s.is_object()) throw std::invalid_argument(field.substr(0, field.size() - 1) + ": not a JSON object");
    if (s.contains("role")) {
      const auto& role = s.at("role");
      if (!role.is_string() || (role != "dark" && role != "white" && role != "subject"))
        throw std::invalid_argument(field + "role: must be dark, white or subject, got " + role.dump().substr(0, 64));
    }
    if (!s.contains("exposure_us") || !s.at("exposure_us").is_number())
      throw std::invalid_argument(field + "exposure_us: missing or not a number");
    if (!s.contains("illumination") || !s.at("illumination").is_object())
      throw std::invalid_argument(field + "illumination: missing or not an object (dark, mix or weights)");
    const auto& illumination = s.at("illumination");
    if (illumination.contains("mix") && !illumination.at("mix").is_string())
      throw std::invalid_argument(field + "illumination.mix: not a string");
    if (illumination.contains("weights")) {
      const auto& weights = illumination.at("weights");
      if (!weights.is_object()) throw std::invalid_argument(field + "illumination.weights: not an object");
      for (const auto& [name, value] : weights.items()) {
        if (!spectral::parse_led_type(name))
          throw std::invalid_argument(field + "illumination.weights." + name.substr(0, 32) +
                                      ": not an LED type (W57, W40, W27, R, G, B)");
        if (!value.is_number())
          throw std::invalid_argument(field + "illumination.weights." + name + ": not a number");
      }
    }
  }
}

}  // namespace

SessionPlan read_plan_file(const std::string& path) {
  std::string text;
  try {
    text = files::read_text_file(path, "session plan");
  } catch (const files::InputFileError& error) {
    throw std::invalid_argument(error.what());
  }
  auto json = nlohmann::json::parse(text, nullptr, false);
  if (json.is_discarded()) throw std::invalid_argument(path + ": not valid JSON");
  if (json.is_object() && json.contains("plan") && !json.contains("steps")) json = json.at("plan");
  try {
    check_plan_json(json);
    SessionPlan plan = plan_from_json(json);
    std::string error;
    if (!plan.IsValid(&error)) throw std::invalid_argument(error);
    return plan;
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(path + ": " + error.what());
  }
}

}  // namespace chromo::session
