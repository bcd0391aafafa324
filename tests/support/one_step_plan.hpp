// The smallest valid plan: one dark step "dark" of 1000 µs, for tests of the
// session folder itself (store, provenance) that capture nothing.
#pragma once

#include "chromo/session/session_plan.hpp"

namespace chromo::testing {
inline session::SessionPlan one_dark_step_plan(const std::string& name = "p") {
  session::SessionPlan plan;
  plan.name = name;
  plan.steps.resize(1);
  plan.steps[0].name = "dark";
  plan.steps[0].role = session::StepRole::kDark;
  plan.steps[0].exposure_us = 1000;
  return plan;
}
}  // namespace chromo::testing
