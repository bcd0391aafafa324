#pragma once
// The simulated controller's own reading and writing of the polarisation
// fields (docs/protocols/led-modbus.md, led-hid.md; never the driver's
// code): a 16-bit word, LED type i in bits 2i..2i+1 (0 unpolarised, 1 cross,
// 2 parallel), bits 12-15 zero; a bank mask, bit i for LED type i.

#include <cstdint>
#include <optional>

#include "chromo/drivers/led_controller.hpp"

namespace chromo::simulators::device_polarisation {

// nullopt for a word the firmware refuses (a code of 3, bits 12-15 set).
inline std::optional<drivers::PolarisationPerType> read_word(std::uint16_t word) {
  if (word & 0xF000u) return std::nullopt;
  drivers::PolarisationPerType polarisation{};
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    const unsigned code = (word >> (2 * i)) & 0x3u;
    if (code == 3) return std::nullopt;
    polarisation[i] = static_cast<drivers::Polarisation>(code);
  }
  return polarisation;
}

inline std::uint16_t write_word(const drivers::PolarisationPerType& polarisation) {
  unsigned word = 0;
  for (int i = 0; i < spectral::kLedTypeCount; ++i) word |= static_cast<unsigned>(polarisation[i]) << (2 * i);
  return static_cast<std::uint16_t>(word);
}

inline std::uint16_t bank_mask(const std::array<bool, spectral::kLedTypeCount>& banks) {
  unsigned mask = 0;
  for (int i = 0; i < spectral::kLedTypeCount; ++i) mask |= (banks[i] ? 1u : 0u) << i;
  return static_cast<std::uint16_t>(mask);
}

}  // namespace chromo::simulators::device_polarisation
