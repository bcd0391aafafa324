#pragma once
// The blue-light hazard of a session plan for the subject's eyes (IEC 62471,
// docs/daemon.md "Blue-light hazard"): what chromod reports for every plan
// it starts and the limit beyond which it refuses one.
//
// Light: each lit step's spectral irradiance at the subject,
//   E(λ) = k · Σ_type drive(type) · spectrum_per_unit_drive(type)(λ)   [W m⁻² nm⁻¹]
// with the LED library's spectra and the configured absolute scale k, given
// as the irradiance (W/m², integrated over 380-780 nm) the W57 LED alone
// produces at the subject at full drive: k = that / ∫ spectrum_per_unit_drive(W57) dλ.
// Weighted: E_B = Σ E(λ)·B(λ)·Δλ (spectral::blue_light_hazard_weighting).
// The sphere's wall is an extended source filling the eye's view, of
// radiance L = E/π (a uniform Lambertian enclosure), so the eye's
// blue-light weighted radiance is L_B = E_B/π.
//
// Dose: L_B · t summed over the subject steps (role subject: the subject is
// in the sphere), t = settle_ms + frames · (exposure + frame_allowance_ms)
// per step (the LEDs stay on while a frame is read out and sent; the
// allowance is that time, configured). Unit J·m⁻²·sr⁻¹, compared with
// IEC 62471's blue-light exposure limit L_B·t ≤ 10⁶ J·m⁻²·sr⁻¹ (t ≤ 10⁴ s),
// the exempt group's (100 W·m⁻²·sr⁻¹ for 10⁴ s). E_B·t (J/m², the
// small-source quantity, limit 100 J/m²) is reported beside it.
//
// Exposures: a metered step's exposure is known only once its white has been
// metered; until then the plan's exposure_us (the first guess) stands in,
// and the sequencer checks the dose again with the metered exposures before
// the first subject step.
//
// Thread rules: pure functions, but for HazardRecord (its own lock).

#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/calibration/led_library.hpp"
#include "chromo/session/session_plan.hpp"

namespace chromo::session {

struct BlueLightHazardOptions {
  // Absolute scale: W57 alone at full drive gives this irradiance at the
  // subject (W/m², 380-780 nm). Default 30 W/m² (about 10,000 lux of a
  // 5700 K white): an assumption until the sphere is measured with a radiometer.
  double w57_full_drive_irradiance_W_per_m2 = 30;
  double limit_J_per_m2_sr = 1e6;   // L_B·t the plan may reach
  double frame_allowance_ms = 100;  // lit time per frame beyond its exposure
  // Names the field: "w57_full_drive_irradiance_W_per_m2: must be > 0".
  bool IsValid(std::string* error) const;
};

struct StepHazard {
  std::string step;
  double weighted_irradiance_W_per_m2 = 0;    // E_B
  double weighted_radiance_W_per_m2_sr = 0;   // L_B = E_B/π
  double lit_s = 0;
  double dose_J_per_m2_sr = 0;                // L_B · lit_s
};

struct PlanHazard {
  std::string plan;
  std::vector<StepHazard> steps;              // the subject steps
  double dose_J_per_m2_sr = 0;                // Σ L_B·t
  double irradiance_dose_J_per_m2 = 0;        // Σ E_B·t
  double limit_J_per_m2_sr = 0;
  bool within_limit() const { return dose_J_per_m2_sr <= limit_J_per_m2_sr; }
  // "plan "standard": blue-light hazard dose 12.3 J·m⁻²·sr⁻¹ (L_B·t over 1.2 s of subject light), limit 1e+06"
  std::string describe() const;
  nlohmann::json to_json() const;
};

// The drive levels of a step (the sequencer's resolution of a mix or weights).
using StepLevels = std::function<drivers::DriveLevels(const Step&)>;

// exposure_us_of_step: exposures known for steps (metered ones); others use
// step.exposure_us. Throws std::invalid_argument for invalid options.
PlanHazard plan_blue_light_hazard(const SessionPlan& plan, const StepLevels& levels, const calibration::LedLibrary& library,
                                  const BlueLightHazardOptions& options,
                                  const std::map<std::string, double>& exposure_us_of_step = {});

// What a session recorded of its dose: the last "blue_light_hazard" record of
// the journal at journal_path (the metered one when the session metered its
// whites, else the planned one), without "type" and "t"; null when the
// journal has none (a folder from before the hazard check, or a hand-made
// one). The session's summary.json reports it as "blue_light_hazard".
// Throws files::InputFileError naming the path when the journal cannot be
// read (not a regular file, beyond the journal size cap).
nlohmann::ordered_json recorded_blue_light_hazard(const std::filesystem::path& journal_path);

// The blue-light hazard a running session has recorded: the planned dose at
// its start, then the metered one once its whites are metered (each also a
// journal record). The daemon's session thread records; the on-line
// estimator reads the latest for summary.json, so nothing re-reads the
// journal the process is writing. Thread rules: any thread (own lock).
class HazardRecord {
 public:
  // Keeps `hazard` as the latest and returns its journal record: the
  // hazard's JSON with "type": "blue_light_hazard" and "exposures".
  nlohmann::json record(const PlanHazard& hazard, const std::string& exposures);
  // The latest as summary.json reports it (its journal record without
  // "type" and "t", as recorded_blue_light_hazard reads it back); null when
  // none was recorded.
  nlohmann::ordered_json latest() const;

 private:
  mutable std::mutex mutex_;
  nlohmann::json latest_;
};

}  // namespace chromo::session
