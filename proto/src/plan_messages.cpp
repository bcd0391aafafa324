#include "chromo/proto/plan_messages.hpp"

#include <string>

namespace chromo::proto {

namespace pb = chromosphere::v1;
using grpc::Status;
using grpc::StatusCode;

pb::Polarisation polarisation_to_proto(drivers::Polarisation polarisation) {
  return polarisation == drivers::Polarisation::kCross      ? pb::POLARISATION_CROSS
         : polarisation == drivers::Polarisation::kParallel ? pb::POLARISATION_PARALLEL
                                                            : pb::POLARISATION_UNPOLARISED;
}

pb::StepRole role_to_proto(session::StepRole role) {
  switch (role) {
    case session::StepRole::kDark: return pb::STEP_ROLE_DARK;
    case session::StepRole::kWhite: return pb::STEP_ROLE_WHITE;
    case session::StepRole::kSubject: return pb::STEP_ROLE_SUBJECT;
  }
  return pb::STEP_ROLE_UNSPECIFIED;
}

void to_proto(const drivers::DriveLevels& levels, pb::DriveLevels* out) {
  out->set_w57(levels[0]);
  out->set_w40(levels[1]);
  out->set_w27(levels[2]);
  out->set_red(levels[3]);
  out->set_green(levels[4]);
  out->set_blue(levels[5]);
}

drivers::DriveLevels from_proto(const pb::DriveLevels& levels) {
  return {levels.w57(), levels.w40(), levels.w27(), levels.red(), levels.green(), levels.blue()};
}

Status check_levels(const drivers::DriveLevels& levels, const std::string& field) {
  static const char* kNames[] = {"w57", "w40", "w27", "red", "green", "blue"};
  for (std::size_t i = 0; i < levels.size(); ++i)
    if (!(levels[i] >= 0 && levels[i] <= 1))
      return {StatusCode::INVALID_ARGUMENT, field + "." + kNames[i] + ": must be in [0, 1], got " + std::to_string(levels[i])};
  return Status::OK;
}


Status from_proto(const pb::SessionPlan& plan, const std::string& field, session::SessionPlan* out) {
  if (!pb::Timing_IsValid(plan.timing())) return {StatusCode::INVALID_ARGUMENT, field + ".timing: unknown value"};
  if (plan.steps_size() > static_cast<int>(session::kMaxSteps))
    return {StatusCode::INVALID_ARGUMENT, field + ".steps: more than " + std::to_string(session::kMaxSteps) + " steps"};
  out->name = plan.name();
  out->timing = plan.timing() == pb::TIMING_HARDWARE ? session::Timing::kHardware : session::Timing::kSoftware;
  for (int i = 0; i < plan.steps_size(); ++i) {
    const auto& s = plan.steps(i);
    const std::string step_field = field + ".steps[" + std::to_string(i) + "]";
    if (!pb::StepRole_IsValid(s.role())) return {StatusCode::INVALID_ARGUMENT, step_field + ".role: unknown value"};
    session::Step step;
    step.name = s.name();
    step.role = s.role() == pb::STEP_ROLE_DARK ? session::StepRole::kDark : s.role() == pb::STEP_ROLE_WHITE ? session::StepRole::kWhite : session::StepRole::kSubject;
    switch (s.illumination_case()) {
      case pb::Step::kDark: step.illumination.kind = session::Illumination::Kind::kDark; break;
      case pb::Step::kWeights:
        step.illumination.kind = session::Illumination::Kind::kWeights;
        step.illumination.weights = from_proto(s.weights());
        if (Status st = check_levels(step.illumination.weights, step_field + ".weights"); !st.ok()) return st;
        break;
      case pb::Step::kMix:
        step.illumination.kind = session::Illumination::Kind::kMix;
        step.illumination.mix = s.mix();
        break;
      default:
        return {StatusCode::INVALID_ARGUMENT, step_field + ".illumination: set one of dark, weights, mix"};
    }
    step.settle_ms = s.settle_ms();
    step.exposure_us = s.exposure_us();
    step.frames_per_camera = s.frames_per_camera();
    step.meter_white_share = s.meter_white_share();
    step.exposure_from = s.exposure_from();
    step.subject_fill = s.subject_fill();
    if (s.subject_percentile() != 0) step.subject_percentile = s.subject_percentile();
    if (s.max_subject_exposure_ratio() != 0) step.max_subject_exposure_ratio = s.max_subject_exposure_ratio();
    step.subject_ratio_from = s.subject_ratio_from();
    step.linearity_of = s.linearity_of();
    if (!pb::Polarisation_IsValid(s.polarisation()))
      return {StatusCode::INVALID_ARGUMENT, step_field + ".polarisation: unknown value " + std::to_string(s.polarisation())};
    step.polarisation = s.polarisation() == pb::POLARISATION_CROSS      ? drivers::Polarisation::kCross
                        : s.polarisation() == pb::POLARISATION_PARALLEL ? drivers::Polarisation::kParallel
                                                                        : drivers::Polarisation::kUnpolarised;
    step.prompt = s.prompt();
    out->steps.push_back(std::move(step));
  }
  std::string error;
  if (!out->IsValid(&error)) return {StatusCode::INVALID_ARGUMENT, field + "." + error};
  return Status::OK;
}

void to_proto(const session::SessionPlan& plan, pb::SessionPlan* out) {
  out->set_name(plan.name);
  out->set_timing(plan.timing == session::Timing::kHardware ? pb::TIMING_HARDWARE : pb::TIMING_SOFTWARE);
  for (const auto& step : plan.steps) {
    auto* s = out->add_steps();
    s->set_name(step.name);
    s->set_role(role_to_proto(step.role));
    switch (step.illumination.kind) {
      case session::Illumination::Kind::kDark: s->set_dark(true); break;
      case session::Illumination::Kind::kWeights: to_proto(step.illumination.weights, s->mutable_weights()); break;
      case session::Illumination::Kind::kMix: s->set_mix(step.illumination.mix); break;
    }
    s->set_settle_ms(step.settle_ms);
    s->set_exposure_us(step.exposure_us);
    s->set_frames_per_camera(step.frames_per_camera);
    s->set_meter_white_share(step.meter_white_share);
    s->set_exposure_from(step.exposure_from);
    s->set_subject_fill(step.subject_fill);
    s->set_subject_percentile(step.subject_percentile);
    s->set_max_subject_exposure_ratio(step.max_subject_exposure_ratio);
    s->set_subject_ratio_from(step.subject_ratio_from);
    s->set_linearity_of(step.linearity_of);
    s->set_polarisation(polarisation_to_proto(step.polarisation));
    s->set_prompt(step.prompt);
  }
}

}  // namespace chromo::proto
