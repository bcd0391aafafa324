// PlanService: the plan advisor over the API (planning.proto, docs/plan-advisor.md).
// Predicts from the daemon's LED library (the built-in nominal one when none
// is calibrated or configured), its configured camera sensitivity and white
// reflectance, and the virtual lab camera's noise model. Every input is
// checked before any work: INVALID_ARGUMENT naming the field.
#include <string>

#include "chromo/calibration/led_library.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/planning/plan_advisor.hpp"
#include "chromo/planning/plan_description.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromosphere/v1/planning.grpc.pb.h"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

constexpr int kMaxPlans = 16;
constexpr int kMaxSkins = 2000;
constexpr std::uint64_t kMaxFits = 20000;

planning::PlanDescription description_from_proto(const pb::PlanDescription& in, const std::string& at) {
  if (in.captures_size() > planning::kMaxPlannedCaptures)
    throw std::invalid_argument(at + "captures: at most " + std::to_string(planning::kMaxPlannedCaptures));
  if (in.channels_size() > planning::kMaxPlannedChannels)
    throw std::invalid_argument(at + "channels: at most " + std::to_string(planning::kMaxPlannedChannels));
  planning::PlanDescription plan;
  plan.name = in.name();
  plan.dark_frames = in.dark_frames() == 0 ? 1 : static_cast<int>(std::min<std::uint32_t>(in.dark_frames(), 1000000));
  for (const pb::PlannedCapture& c : in.captures()) {
    planning::PlannedCapture capture;
    capture.name = c.name();
    const pb::DriveLevels& d = c.drive();
    capture.drive = {d.w57(), d.w40(), d.w27(), d.red(), d.green(), d.blue()};
    if (c.white_fill() != 0) capture.white_fill = c.white_fill();
    // Out-of-range counts stay out of range (clamped only to fit an int) so IsValid names them.
    capture.frames = c.frames() == 0 ? 1 : static_cast<int>(std::min<std::uint32_t>(c.frames(), 1000000));
    capture.white_frames =
        c.white_frames() == 0 ? capture.frames : static_cast<int>(std::min<std::uint32_t>(c.white_frames(), 1000000));
    capture.settle_ms = static_cast<int>(std::min<std::uint32_t>(c.settle_ms(), 1000000));
    plan.captures.push_back(std::move(capture));
  }
  for (const pb::PlannedChannel& c : in.channels()) {
    if (!pb::CameraChannel_IsValid(c.camera_channel()))
      throw std::invalid_argument(at + "channels: camera_channel: unknown value");
    plan.channels.push_back({c.capture(), static_cast<int>(c.camera_channel()), c.minus()});
  }
  if (std::string error; !plan.IsValid(&error)) throw std::invalid_argument(at + error);
  return plan;
}

void sigma_to_proto(const planning::ParameterSigma& s, pb::ParameterSigma* out) {
  out->set_cm(s.cm), out->set_ch(s.ch), out->set_bm(s.bm), out->set_che(s.che);
}

class PlanServiceImpl final : public pb::PlanService::Service {
 public:
  PlanServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}

  Status ComparePlans(ServerContext* context, const pb::ComparePlansRequest* request,
                      pb::ComparePlansResponse* response) override {
    return guard_(context, [&]() -> Status {
      if (request->plans_size() < 1 || request->plans_size() > kMaxPlans)
        return invalid("plans: must hold 1-" + std::to_string(kMaxPlans) + " plans");
      if (request->skins() > kMaxSkins) return invalid("skins: at most " + std::to_string(kMaxSkins));
      const int skins = request->skins() == 0 ? 64 : static_cast<int>(request->skins());
      if (static_cast<std::uint64_t>(request->plans_size()) * skins * request->monte_carlo_draws() > kMaxFits)
        return invalid("monte_carlo_draws: plans × skins × draws must be at most " + std::to_string(kMaxFits));
      std::shared_ptr<const calibration::LedLibrary> library = daemon_.calibrations().library();
      std::string library_name = daemon_.calibrations().library_path();
      if (!library) {
        library = std::make_shared<const calibration::LedLibrary>(calibration::nominal_led_library());
        library_name = "built-in nominal";
      }
      std::vector<planning::PlanDescription> plans;
      for (int i = 0; i < request->plans_size(); ++i) {
        const pb::PlanChoice& choice = request->plans(i);
        const std::string at = "plans[" + std::to_string(i) + "].";
        switch (choice.plan_case()) {
          case pb::PlanChoice::kBuiltin:
            try {
              plans.push_back(planning::builtin_plan(choice.builtin(), *library));
            } catch (const std::invalid_argument& e) {
              return invalid(at + "builtin: " + e.what());
            }
            break;
          case pb::PlanChoice::kDescription:
            try {
              plans.push_back(description_from_proto(choice.description(), at + "description."));
            } catch (const std::invalid_argument& e) {
              return invalid(e.what());
            }
            break;
          default:
            return invalid(at + "plan: required (builtin or description)");
        }
      }
      const EstimationConfig& estimation = daemon_.config().estimation;
      planning::CameraNoise camera;
      const std::string& sensitivity = estimation.camera_sensitivity;
      camera.sensitivity = sensitivity.rfind("builtin:", 0) == 0 ? spectral::builtin_camera(sensitivity.substr(8))
                                                                 : spectral::read_camera_sensitivity(sensitivity);
      camera.white_reflectance = estimation.white_reflectance;
      planning::AdvisorOptions options;
      if (request->interior_population()) options.population = planning::interior_population();
      options.population.count = skins;
      options.population.seed = request->seed() == 0 ? 1 : request->seed();
      options.threads = 2;
      // The estimator's discrepancy (estimation.discrepancy), so the advice weighs the channels as the maps will.
      if (estimation.discrepancy != "none") options.discrepancy = estimation::ModelDiscrepancy::standard();
      planning::MonteCarloOptions mc;
      mc.draws_per_skin = std::max<int>(1, static_cast<int>(request->monte_carlo_draws()));
      for (std::size_t i = 0; i < plans.size(); ++i) {
        // A plan whose channels see no light of this library: INVALID_ARGUMENT naming it.
        planning::PlanPrediction p;
        try {
          p = planning::predict_plan(plans[i], *library, camera, options);
        } catch (const std::invalid_argument& e) {
          return invalid("plans[" + std::to_string(i) + "]: " + e.what());
        }
        pb::PlanAdvice* advice = response->add_plans();
        advice->set_plan(p.plan);
        for (const std::string& c : p.channels) advice->add_channels(c);
        advice->set_subject_s(p.time.subject_s);
        advice->set_reference_s(p.time.reference_s);
        for (const auto& c : p.time.captures) {
          pb::CaptureTiming* t = advice->add_captures();
          t->set_name(c.name), t->set_exposure_us(c.exposure_us), t->set_subject_s(c.subject_s), t->set_white_s(c.white_s);
        }
        sigma_to_proto(p.sigma, advice->mutable_sigma());
        for (const std::string& name : p.illuminants) advice->add_illuminants(name);
        for (double d : p.delta_e94) advice->add_predicted_delta_e94(d);
        advice->set_predicted_delta_e94_mean(p.delta_e94_mean);
        if (request->monte_carlo_draws() > 0) {
          const planning::MonteCarloCheck check = planning::monte_carlo_check(plans[i], *library, camera, options, mc, p);
          advice->set_checked(true);
          for (double d : check.delta_e94) advice->add_monte_carlo_delta_e94(d);
          advice->set_monte_carlo_delta_e94_mean(check.delta_e94_mean);
          advice->set_ratio(check.ratio);
          advice->set_bound_share(check.bound_share);
          advice->set_fits(static_cast<std::uint32_t>(check.fits));
          sigma_to_proto(check.rms_error, advice->mutable_monte_carlo_rms_error());
        }
      }
      response->set_library(library_name);
      response->set_camera(sensitivity);
      return Status::OK;
    });
  }

 private:
  Daemon& daemon_;
  Guard& guard_;
};

}  // namespace

std::unique_ptr<grpc::Service> make_plan_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<PlanServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
