// Daemon::session_provenance: what a session starting now is made with (session/session_provenance.hpp).
#include <chrono>

#include "chromo/daemon/daemon.hpp"
#include "chromo/drivers/led_controller.hpp"
#include "chromo/maps/estimator_version.hpp"

namespace chromo::daemon {

session::SessionProvenance Daemon::session_provenance(const session::SessionPlan& plan,
                                                      const SessionPeople& people) const {
  session::SessionProvenance provenance;
  provenance.recorded = true;
  const session::CaptureSources sources = light_sources();
  const bool nominal = sources.led_library.source == "nominal";
  provenance.led_library.kind = sources.led_library.source;
  provenance.led_library.file = nominal ? "" : sources.led_library_source;
  provenance.led_library.created_utc = sources.led_library.created_utc;
  // The built-in library's date is its data's, not a measurement of this sphere: no age.
  provenance.led_library.age_at_start_s =
      nominal ? -1 : session::seconds_since(sources.led_library.created_utc, std::chrono::system_clock::now());
  for (const auto& step : plan.steps) {
    if (step.illumination.kind != session::Illumination::Kind::kMix) continue;
    std::string key = step.illumination.mix;
    if (step.polarisation != drivers::Polarisation::kUnpolarised)
      key += std::string(" (") + drivers::polarisation_name(step.polarisation) + ")";
    const bool solved = calibrations_->solved_mix(step.illumination.mix, step.polarisation).has_value();
    provenance.mixes[key] = {resolve_mix(step.illumination.mix, step.polarisation),
                             solved ? "solved from the calibrated LED library" : "configured (mixes)"};
  }
  provenance.camera_sensitivity = sources.camera_source;
  provenance.camera_sensitivity_of = config_.estimation.camera_sensitivities;
  provenance.camera_field_width_mm = config_.estimation.camera_field_width_mm;
  provenance.white_reflectance = sources.white_reflectance;
  provenance.plan = plan.name;
  provenance.operator_name = people.operator_name;
  provenance.study = people.study;
  provenance.estimator_version = maps::estimator_version();
  provenance.estimator_options = {{"method", config_.estimation.method},
                                  {"model", config_.estimation.model},
                                  {"discrepancy", config_.estimation.discrepancy},
                                  {"skin_denoise", config_.estimation.skin_denoise},
                                  {"local_bias", config_.estimation.local_bias},
                                  {"registration_tiles", config_.estimation.registration_tiles},
                                  {"discrepancy_layer", config_.estimation.discrepancy_layer},
                                  {"films_extinction_ratio", config_.estimation.films_extinction_ratio}};
  return provenance;
}

}  // namespace chromo::daemon
