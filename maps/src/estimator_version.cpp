#include "chromo/maps/estimator_version.hpp"

#include <fmt/format.h>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/cie.hpp"

#ifndef CHROMO_VERSION
#define CHROMO_VERSION "unknown"
#endif

namespace chromo::maps {

std::string estimator_version() {
  static const std::string version = [] {
    const estimation::MeasurementSet probe =
        estimation::rgb_measurement_set(spectral::builtin_camera("nikon_d5100"), spectral::illuminant_d65());
    return fmt::format("chromosphere {}; model+tables {:016x}", CHROMO_VERSION,
                       estimation::ForwardTable::cache_key(probe, estimation::TableGrid{}));
  }();
  return version;
}

}  // namespace chromo::maps
