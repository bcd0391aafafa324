#include "chromo/daemon/internal/capture/white_balance.hpp"

#include <algorithm>
#include <stdexcept>

namespace chromo::daemon {

std::array<double, 3> white_balance_gains(const calibration::LedLibrary& library, const spectral::CameraSensitivity& camera,
                                          const drivers::DriveLevels& drive) {
  spectral::Spectrum light;
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    if (drive[i] > 0) light = light + library.leds[i].spectrum_per_unit_drive() * drive[i];
  // A white target's raw response per channel: ∫ S_c E dλ (camera_response
  // normalises each channel to a white of 1, which would hide the balance).
  std::array<double, 3> white{};
  for (int c = 0; c < 3; ++c) white[c] = (camera.rgb[c] * light).integral();
  if (!(std::min({white[0], white[1], white[2]}) > 0))
    throw std::invalid_argument("white balance: the LEDs light no camera channel");
  const auto gain = [&](int c) { return std::clamp(white[1] / white[c], 1.0 / 64, 64.0); };
  return {gain(0), 1.0, gain(2)};
}

}  // namespace chromo::daemon
