#include "polarisation_word.hpp"

#include "chromo/drivers/device_error.hpp"

namespace chromo::drivers::detail {

std::uint16_t encode_polarisation_word(const PolarisationPerType& polarisation) {
  std::uint16_t word = 0;
  for (int i = 0; i < kLedTypeCount; ++i)
    word = static_cast<std::uint16_t>(word | (static_cast<unsigned>(polarisation[i]) & 0x3u) << (2 * i));
  return word;
}

PolarisationPerType decode_polarisation_word(std::uint16_t word, const std::string& device, const std::string& field) {
  if (word >> (2 * kLedTypeCount))
    throw DeviceError(DeviceError::Kind::kProtocol, device, "read " + field,
                      "polarisation word " + std::to_string(word) + " has bits 12-15 set");
  PolarisationPerType polarisation{};
  for (LedType type : spectral::kAllLedTypes) {
    const int i = led_type_index(type);
    const unsigned code = (word >> (2 * i)) & 0x3u;
    if (code >= kPolarisationCodeCount)
      throw DeviceError(DeviceError::Kind::kProtocol, device, "read " + field,
                        "polarisation code " + std::to_string(code) + " for " + std::string(led_type_name(type)) +
                            " (0 unpolarised, 1 cross, 2 parallel)");
    polarisation[i] = static_cast<Polarisation>(code);
  }
  return polarisation;
}

std::uint16_t encode_polariser_bank_mask(const std::array<bool, kLedTypeCount>& banks) {
  std::uint16_t mask = 0;
  for (int i = 0; i < kLedTypeCount; ++i)
    if (banks[i]) mask = static_cast<std::uint16_t>(mask | 1u << i);
  return mask;
}

std::array<bool, kLedTypeCount> decode_polariser_bank_mask(std::uint16_t mask, const std::string& device,
                                                           const std::string& field) {
  if (mask >> kLedTypeCount)
    throw DeviceError(DeviceError::Kind::kProtocol, device, "read " + field,
                      "polariser bank mask " + std::to_string(mask) + " has bits above the six LED types set");
  std::array<bool, kLedTypeCount> banks{};
  for (int i = 0; i < kLedTypeCount; ++i) banks[i] = (mask >> i) & 1u;
  return banks;
}

}  // namespace chromo::drivers::detail
