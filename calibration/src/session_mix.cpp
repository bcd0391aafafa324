#include "chromo/calibration/session_mix.hpp"

#include <stdexcept>

#include "chromo/calibration/mix_solver.hpp"
#include "chromo/calibration/mix_target.hpp"

namespace chromo::calibration {

MixSolverOptions session_mix_solver_options(const std::string& objective, bool hold_chromaticity) {
  MixSolverOptions options;
  const auto parsed = parse_mix_objective(objective);
  if (!parsed) throw std::invalid_argument("objective: \"" + objective.substr(0, 64) + "\" is not spectral, xyz or camera");
  options.objective = *parsed;
  options.hold_chromaticity = hold_chromaticity;
  if (std::string error; !options.IsValid(&error)) throw std::invalid_argument(error);
  return options;
}

SolvedMix solve_session_mix(const LedLibrary& library, const std::string& target,
                            const std::string& objective, bool hold_chromaticity) {
  const MixSolverOptions options = session_mix_solver_options(objective, hold_chromaticity);
  // "w57" / "w57:R": W57 alone at its level in "w57+blue" / "w57+blue:R".
  const bool w57_alone = target == "w57" || target.rfind("w57:", 0) == 0;
  MixTarget mix_target;
  try {
    mix_target = parse_mix_target(w57_alone ? "w57+blue" + target.substr(3) : target, library, options.camera);
  } catch (const std::exception& e) {
    throw std::invalid_argument("target: " + std::string(e.what()));
  }
  const auto summary = solve_mix(library, mix_target, options);
  if (!summary.IsSolutionUsable())
    throw std::invalid_argument("target \"" + target.substr(0, 64) + "\": " +
                                std::string(mix_termination_name(summary.termination)) + ": " + summary.message);
  SolvedMix solved;
  for (std::size_t i = 0; i < solved.weights.size(); ++i) solved.weights[i] = summary.weights[i];
  if (w57_alone) {
    for (std::size_t i = 0; i < solved.weights.size(); ++i)
      if (i != static_cast<std::size_t>(spectral::led_type_index(spectral::LedType::kW57))) solved.weights[i] = 0;
  }
  solved.figures = {{"rmse", summary.rmse},
                    {"delta_uv_prime", summary.delta_uv_prime},
                    {"ra", summary.rendering.ra},
                    {"cct_K", summary.rendering.cct_K},
                    {"camera_de00_mean", summary.camera_de00.mean},
                    {"camera_de00_max", summary.camera_de00.max}};
  solved.summary = (w57_alone ? target + ": the W57 level of the w57+blue" + target.substr(3) + " solve, other LEDs off. "
                              : std::string()) +
                   summary.BriefReport();
  return solved;
}

}  // namespace chromo::calibration
