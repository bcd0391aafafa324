#pragma once
// FixedSpectrumIllumination: a trivial SphereIllumination that emits one
// spectrum set by hand. For camera-simulator tests and for chromo-sim until
// the LED model of the virtual lab is attached; it has no drift, no warm-up
// and no drive levels. Thread-safe.

#include <mutex>

#include "chromo/simulators/sphere_illumination.hpp"

namespace chromo::simulators {

class FixedSpectrumIllumination final : public SphereIllumination {
 public:
  explicit FixedSpectrumIllumination(const spectral::Spectrum& irradiance) : irradiance_(irradiance) {}

  void set(const spectral::Spectrum& irradiance) {
    std::lock_guard lock(mutex_);
    irradiance_ = irradiance;
  }
  spectral::Spectrum irradiance_now() const override {
    std::lock_guard lock(mutex_);
    return irradiance_;
  }
  // Linear interpolation between grid samples (0 outside 380-780 nm).
  double irradiance_at_nm(double wavelength_nm) const override {
    const double position = (wavelength_nm - spectral::kGridStartNm) / spectral::kGridStepNm;
    if (position < 0 || position > spectral::kGridSize - 1) return 0;
    const int i = std::min(static_cast<int>(position), spectral::kGridSize - 2);
    const double t = position - i;
    std::lock_guard lock(mutex_);
    return (1 - t) * irradiance_[i] + t * irradiance_[i + 1];
  }

 private:
  mutable std::mutex mutex_;
  spectral::Spectrum irradiance_;
};

}  // namespace chromo::simulators
