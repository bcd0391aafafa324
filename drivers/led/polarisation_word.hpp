#pragma once
// The driver's encoding of the polarisation fields of both LED controller
// protocols (docs/protocols/led-modbus.md, led-hid.md): a 16-bit word with
// two bits per LED type (type i in bits 2i..2i+1: 0 unpolarised, 1 cross,
// 2 parallel), bits 12-15 zero; and a polariser bank mask (bit i: LED type i
// has a cross and a parallel bank), bits 6 and up zero.

#include <cstdint>
#include <string>

#include "chromo/drivers/led_controller.hpp"

namespace chromo::drivers::detail {

std::uint16_t encode_polarisation_word(const PolarisationPerType& polarisation);
// Throws DeviceError(kProtocol) naming `field` for a code of 3 or bits 12-15 set.
PolarisationPerType decode_polarisation_word(std::uint16_t word, const std::string& device, const std::string& field);

std::uint16_t encode_polariser_bank_mask(const std::array<bool, kLedTypeCount>& banks);
// Throws DeviceError(kProtocol) naming `field` for bits 6-15 set.
std::array<bool, kLedTypeCount> decode_polariser_bank_mask(std::uint16_t mask, const std::string& device,
                                                           const std::string& field);

}  // namespace chromo::drivers::detail
