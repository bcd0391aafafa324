#include "plan_advice.hpp"

#include <map>
#include <stdexcept>

#include "chromo/calibration/session_mix.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/planning/plan_advisor.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/spectral/camera.hpp"

namespace chromo::cli {
namespace {

constexpr double kFixedExposureWhiteShare = 0.85;

// A step's drive levels: a named mix solved from the library as the daemon
// solves it (camera objective), or the step's own weights; dark for a dark step.
drivers::DriveLevels step_drive(const session::SessionPlan& plan, const session::Step& step,
                                const calibration::LedLibrary& library) {
  switch (step.illumination.kind) {
    case session::Illumination::Kind::kDark: return drivers::DriveLevels{};
    case session::Illumination::Kind::kWeights: return step.illumination.weights;
    case session::Illumination::Kind::kMix: break;
  }
  try {
    return calibration::solve_session_mix(library, step.illumination.mix, "camera", false).weights;
  } catch (const std::exception& e) {
    throw std::invalid_argument(plan.name + ": step " + step.name + ": " + e.what());
  }
}

}  // namespace

std::optional<planning::PlanDescription> advisor_plan(const session::SessionPlan& plan,
                                                      const calibration::LedLibrary& library) {
  planning::PlanDescription description;
  description.name = plan.name;
  std::map<std::string, const session::Step*> white_of;  // by illumination state key
  for (const session::Step& step : plan.steps) {
    if (step.role == session::StepRole::kWhite) white_of[session::illumination_state(step).key] = &step;
    if (step.role == session::StepRole::kDark) description.dark_frames = static_cast<int>(step.frames_per_camera);
  }
  for (const session::Step& step : plan.steps) {
    if (step.role != session::StepRole::kSubject) continue;
    planning::PlannedCapture capture;
    const session::IlluminationState state = session::illumination_state(step);
    capture.name = state.name;
    capture.drive = step_drive(plan, step, library);
    capture.frames = static_cast<int>(step.frames_per_camera);
    capture.settle_ms = static_cast<int>(step.settle_ms);
    if (const auto white = white_of.find(state.key); white != white_of.end()) {
      capture.white_frames = static_cast<int>(white->second->frames_per_camera);
      capture.white_fill =
          white->second->meter_white_share > 0 ? white->second->meter_white_share : kFixedExposureWhiteShare;
    }
    description.captures.push_back(capture);
  }
  if (description.captures.empty()) return std::nullopt;
  const auto index = [&](const char* name) { return description.capture_index(name); };
  if (description.captures.size() == 3 && index("d65") >= 0 && index("w57") >= 0 && index("w57+blue") >= 0) {
    for (int c = 0; c < 3; ++c) description.channels.push_back({"d65", c, ""});
    description.channels.push_back({"w57+blue", 2, "w57"});
  }
  if (std::string error; !description.IsValid(&error)) throw std::invalid_argument(plan.name + ": " + error);
  return description;
}

std::optional<double> predicted_relit_delta_e94(const session::SessionPlan& plan) {
  const calibration::LedLibrary library = simulators::lab_led_library();
  const auto description = advisor_plan(plan, library);
  if (!description) return std::nullopt;
  planning::CameraNoise camera;
  camera.sensitivity = spectral::builtin_camera("nikon_d5100");
  planning::AdvisorOptions options;  // as `chromo plan compare` by default: the learned discrepancy in
  options.discrepancy = estimation::ModelDiscrepancy::standard();
  return planning::predict_plan(*description, library, camera, options).delta_e94_mean;
}

session::PlanHazard planned_blue_light_hazard(const session::SessionPlan& plan) {
  const calibration::LedLibrary library = simulators::lab_led_library();
  return session::plan_blue_light_hazard(
      plan, [&](const session::Step& step) { return step_drive(plan, step, library); }, library,
      session::BlueLightHazardOptions{});
}

}  // namespace chromo::cli
