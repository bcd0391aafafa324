#pragma once
// The plan advisor (planning/) behind `chromo session plans`: a session plan
// converted into the advisor's description, and its predicted relit ΔE94 on
// skin (the mean over D65, A and the six LEDs, docs/plan-advisor.md).
//
// Conversion (advisor_plan): each subject step is a capture, lit as the step
// says (a named mix solved from the library as the daemon solves it, or the
// step's own weights); its frames, its white step's frames and its settle
// time carry over. A white step that meters (meter_white_share) gives that
// share; a white step with a fixed exposure is taken at 0.85 of full scale,
// the share the virtual lab exposes its brightest white to (an
// approximation: its dimmer whites sit lower). The method's plan (subjects
// under d65, w57 and w57+blue, any blue ratio) has the method's four
// channels, D65'.R, G, B and (W57+blue − W57).B; any other plan every
// capture's R, G and B. Prediction uses the virtual lab's true-LED library
// and the lab camera's noise, as `chromo plan compare` does by default.

#include <optional>
#include <string>

#include "chromo/calibration/led_library.hpp"
#include "chromo/planning/plan_description.hpp"
#include "chromo/session/plan_hazard.hpp"
#include "chromo/session/session_plan.hpp"

namespace chromo::cli {

// std::nullopt when the plan has no subject step; std::invalid_argument
// naming the step when a mix cannot be solved.
std::optional<planning::PlanDescription> advisor_plan(const session::SessionPlan& plan,
                                                      const calibration::LedLibrary& library);

// The advisor's prediction (64 skins of the whole range), or std::nullopt
// when the plan has nothing it can predict (no subject step).
std::optional<double> predicted_relit_delta_e94(const session::SessionPlan& plan);

// The plan's blue-light hazard dose for the subject's eyes (IEC 62471,
// session/plan_hazard.hpp) at its planned exposures, from the same library
// and chromod's default absolute scale and allowance (BlueLightHazardOptions'
// defaults: docs/config.md "hazard"). A metered plan's planned exposures are
// its first guesses; chromod checks the dose again once metered.
// std::invalid_argument naming the step when a mix cannot be solved.
session::PlanHazard planned_blue_light_hazard(const session::SessionPlan& plan);

}  // namespace chromo::cli
