#include "chromo/session/plan_hazard.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "chromo/session/journal.hpp"
#include "chromo/spectral/cie.hpp"

namespace chromo::session {

bool BlueLightHazardOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (!(w57_full_drive_irradiance_W_per_m2 > 0 && w57_full_drive_irradiance_W_per_m2 <= 1e5))
    return fail("w57_full_drive_irradiance_W_per_m2: must be in (0, 100000]");
  if (!(limit_J_per_m2_sr > 0 && limit_J_per_m2_sr <= 1e12)) return fail("limit_J_per_m2_sr: must be in (0, 1e12]");
  if (!(frame_allowance_ms >= 0 && frame_allowance_ms <= 60000)) return fail("frame_allowance_ms: must be in [0, 60000]");
  return true;
}

std::string PlanHazard::describe() const {
  double lit = 0;
  for (const auto& s : steps) lit += s.lit_s;
  char text[320];
  std::snprintf(text, sizeof text,
                "plan \"%s\": blue-light hazard dose %.4g J/(m2 sr) (IEC 62471 L_B*t over %.3g s of light on the subject; "
                "E_B*t %.4g J/m2), limit %.4g J/(m2 sr)",
                plan.c_str(), dose_J_per_m2_sr, lit, irradiance_dose_J_per_m2, limit_J_per_m2_sr);
  return text;
}

nlohmann::json PlanHazard::to_json() const {
  nlohmann::json per_step = nlohmann::json::array();
  for (const auto& s : steps)
    per_step.push_back({{"step", s.step},
                        {"weighted_irradiance_W_per_m2", s.weighted_irradiance_W_per_m2},
                        {"weighted_radiance_W_per_m2_sr", s.weighted_radiance_W_per_m2_sr},
                        {"lit_s", s.lit_s},
                        {"dose_J_per_m2_sr", s.dose_J_per_m2_sr}});
  return {{"plan", plan},
          {"dose_J_per_m2_sr", dose_J_per_m2_sr},
          {"irradiance_dose_J_per_m2", irradiance_dose_J_per_m2},
          {"limit_J_per_m2_sr", limit_J_per_m2_sr},
          {"within_limit", within_limit()},
          {"steps", per_step}};
}

PlanHazard plan_blue_light_hazard(const SessionPlan& plan, const StepLevels& levels, const calibration::LedLibrary& library,
                                  const BlueLightHazardOptions& options,
                                  const std::map<std::string, double>& exposure_us_of_step) {
  if (std::string error; !options.IsValid(&error)) throw std::invalid_argument("hazard." + error);
  const double w57_integral =
      library.led(spectral::LedType::kW57).spectrum_per_unit_drive().values().sum() * spectral::kGridStepNm;
  if (!(w57_integral > 0)) throw std::invalid_argument("LED library: the W57 spectrum is zero (no absolute scale)");
  const double scale = options.w57_full_drive_irradiance_W_per_m2 / w57_integral;  // W m⁻² nm⁻¹ per library unit
  const spectral::Spectrum& weighting = spectral::blue_light_hazard_weighting();
  PlanHazard out;
  out.plan = plan.name;
  out.limit_J_per_m2_sr = options.limit_J_per_m2_sr;
  for (const Step& step : plan.steps) {
    if (step.role != StepRole::kSubject || step.illumination.kind == Illumination::Kind::kDark) continue;
    const drivers::DriveLevels drive = levels(step);
    spectral::Spectrum irradiance;
    for (auto type : spectral::kAllLedTypes)
      irradiance += library.led(type).spectrum_per_unit_drive() *
                    drive[static_cast<std::size_t>(spectral::led_type_index(type))];
    StepHazard h;
    h.step = step.name;
    h.weighted_irradiance_W_per_m2 = scale * (irradiance.values() * weighting.values()).sum() * spectral::kGridStepNm;
    h.weighted_radiance_W_per_m2_sr = h.weighted_irradiance_W_per_m2 / std::numbers::pi;
    const auto known = exposure_us_of_step.find(step.name);
    const double exposure_us = known != exposure_us_of_step.end() ? known->second : step.exposure_us;
    h.lit_s = 1e-3 * step.settle_ms + step.frames_per_camera * (1e-6 * exposure_us + 1e-3 * options.frame_allowance_ms);
    h.dose_J_per_m2_sr = h.weighted_radiance_W_per_m2_sr * h.lit_s;
    out.dose_J_per_m2_sr += h.dose_J_per_m2_sr;
    out.irradiance_dose_J_per_m2 += h.weighted_irradiance_W_per_m2 * h.lit_s;
    out.steps.push_back(std::move(h));
  }
  return out;
}

namespace {
constexpr const char* kHazardRecordType = "blue_light_hazard";

// A hazard journal record as summary.json reports it: without "type" and
// "t", in the journal's (sorted) key order; null stays null.
nlohmann::ordered_json reported_hazard(nlohmann::json record) {
  if (record.is_object()) {
    record.erase("type");
    record.erase("t");
  }
  return nlohmann::ordered_json(record);
}
}  // namespace

nlohmann::ordered_json recorded_blue_light_hazard(const std::filesystem::path& journal_path) {
  nlohmann::json last;
  for (const nlohmann::json& record : read_journal(journal_path).records)
    if (const auto type = record.find("type"); type != record.end() && *type == kHazardRecordType) last = record;
  return reported_hazard(std::move(last));
}

nlohmann::json HazardRecord::record(const PlanHazard& hazard, const std::string& exposures) {
  nlohmann::json record = hazard.to_json();
  record["type"] = kHazardRecordType;
  record["exposures"] = exposures;
  std::lock_guard lock(mutex_);
  latest_ = record;
  return record;
}

nlohmann::ordered_json HazardRecord::latest() const {
  std::lock_guard lock(mutex_);
  return reported_hazard(latest_);
}

}  // namespace chromo::session
