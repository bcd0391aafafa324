#pragma once
// Spectrometer: a USB array spectrometer (Ocean Optics USB2000+/Flame command
// set), reached through raw USB bulk transfers. This interface is the device's
// own vocabulary (raw counts per pixel); SpectrometerReader (spectrometer_reader.hpp)
// adds auto-ranging, dark subtraction, the non-linearity correction and the
// stale-first-spectrum rule on top of any Spectrometer.
//
// Thread rules: one thread at a time. Every call completes or throws DeviceError.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace chromo::drivers {

struct SpectrometerInfo {
  std::string model;
  std::string serial;
  int pixel_count = 0;
  // λ(pixel) = c0 + c1·p + c2·p² + c3·p³ (nm), from the device's EEPROM.
  std::array<double, 4> wavelength_coefficients{};
  // Non-linearity polynomial (order ≤ 7) from the EEPROM: the corrected count
  // is raw / Σ k_i·raw^i (Ocean Optics' convention).
  std::vector<double> nonlinearity_coefficients;
  double saturation_counts = 65535;
  std::uint32_t min_integration_time_us = 1000;
  std::uint32_t max_integration_time_us = 65000000;
};

struct RawSpectrum {
  std::vector<double> counts;           // one per pixel, as read
  std::uint32_t integration_time_us = 0;
};

struct SpectrometerStatus {
  std::uint32_t integration_time_us = 0;
  int pixel_count = 0;
  bool lamp_enabled = false;
  bool data_ready = false;
};

class Spectrometer {
 public:
  virtual ~Spectrometer() = default;
  virtual SpectrometerInfo info() const = 0;
  virtual void set_integration_time_us(std::uint32_t integration_time_us) = 0;
  virtual RawSpectrum read_raw_spectrum() = 0;
  virtual SpectrometerStatus read_status() = 0;
};

}  // namespace chromo::drivers
