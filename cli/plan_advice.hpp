#pragma once
// The seam for the plan advisor (another library, being written): the
// predicted accuracy of a plan (relit ΔE94 expected on skin) that `chromo
// session plans` prints in its last column. Until the advisor exists it
// predicts nothing and the column shows "-"; linking the advisor means
// replacing the body of predicted_relit_delta_e94 with its call.

#include <optional>

#include "chromo/session/session_plan.hpp"

namespace chromo::cli {

inline std::optional<double> predicted_relit_delta_e94(const session::SessionPlan&) { return std::nullopt; }

}  // namespace chromo::cli
