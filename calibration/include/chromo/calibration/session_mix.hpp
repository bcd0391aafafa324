#pragma once
// The LED drive levels of the mixes a session names ("d65", "w57",
// "w57+blue[:R]", ...), solved from an LED library with the mix solver: what
// chromod's Calibrations and the rendered test sessions both use.

#include <map>
#include <string>

#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/mix_solver.hpp"
#include "chromo/drivers/led_controller.hpp"

namespace chromo::calibration {

// The mix solver's options for an objective named "spectral", "xyz" or
// "camera"; std::invalid_argument naming "objective" otherwise.
MixSolverOptions session_mix_solver_options(const std::string& objective, bool hold_chromaticity);

struct SolvedMix {
  drivers::DriveLevels weights{};
  std::map<std::string, double> figures;  // rmse, delta_uv_prime, ra, camera_de00_mean, camera_de00_max
  std::string summary;                    // MixSummary::BriefReport()
  std::string library;                    // the library file used
};

// The drive levels of a mix `target` ("d65", "w57", "w57+blue[:R]", "cct:K",
// a CSV path) from `library` under `objective` ("spectral", "xyz",
// "camera"), as sessions get them (Calibrations::solved_mix uses "camera").
// "w57" ("w57:R") is W57 alone at the level it has in the w57+blue
// (w57+blue:R) solve, so that the
// method's blue-only response (W57+blue) − W57 holds exactly. std::invalid_argument
// naming "target"/"objective" for a bad request or an unusable solve.
// (library is left empty.) A pure function.
SolvedMix solve_session_mix(const LedLibrary& library, const std::string& target,
                            const std::string& objective, bool hold_chromaticity);

}  // namespace chromo::calibration
