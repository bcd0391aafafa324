#pragma once
// The live view's white balance (docs/web.md "Live"): the gains that make a
// white target grey in a camera's picture under the LEDs as they are driven,
// predicted from the LED library and the camera's spectral sensitivity.

#include <array>
#include <string>

#include "chromo/calibration/led_library.hpp"
#include "chromo/drivers/led_controller.hpp"
#include "chromo/spectral/camera.hpp"

namespace chromo::daemon {

struct WhiteBalance {
  std::array<double, 3> gains{1, 1, 1};  // R, G, B multipliers of the picture
  std::string description = "none: raw";  // what they came from, or why there are none
};

// A white (albedo 1) target's camera response under Σ drive_i × the
// library's spectrum per unit drive of LED i, as gains G/R, 1, G/B, each
// clamped to [1/64, 64]. std::invalid_argument when the LEDs light no
// channel (every drive 0, or a response ≤ 0).
std::array<double, 3> white_balance_gains(const calibration::LedLibrary& library, const spectral::CameraSensitivity& camera,
                                          const drivers::DriveLevels& drive);

}  // namespace chromo::daemon
