#pragma once
// The driver's side of the Ocean Optics command set: byte encoders for the
// commands and parsers for the replies (docs/protocols/spectrometer.md).
// Parsers throw DeviceError(kProtocol) naming the device and what was wrong
// for any reply that is short, oversized or malformed.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "chromo/drivers/spectrometer.hpp"

namespace chromo::drivers::ocean_optics {

std::vector<std::uint8_t> encode_initialize();
std::vector<std::uint8_t> encode_set_integration_time(std::uint32_t integration_time_us);
std::vector<std::uint8_t> encode_query_information(std::uint8_t slot);
std::vector<std::uint8_t> encode_request_spectrum();
std::vector<std::uint8_t> encode_query_status();

// The slot's text (up to the first NUL) from a 17-byte information reply.
std::string parse_information_reply(std::span<const std::uint8_t> reply, std::uint8_t slot, const std::string& device);
// A slot's text as a number ("3.39500e+02"); surrounding blanks allowed, nothing else.
double parse_information_number(const std::string& text, std::uint8_t slot, const std::string& device);
SpectrometerStatus parse_status_reply(std::span<const std::uint8_t> reply, const std::string& device);
// The whole spectrum transfer (2·pixels bytes, little-endian u16 per pixel, then the sync byte).
std::vector<double> parse_spectrum(std::span<const std::uint8_t> bytes, int pixel_count, const std::string& device);

}  // namespace chromo::drivers::ocean_optics
