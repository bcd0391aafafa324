#include "chromo/drivers/spectrometer/ocean_optics_messages.hpp"

#include <cctype>
#include <cerrno>
#include <cstdlib>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/spectrometer/ocean_optics_protocol.hpp"

namespace chromo::drivers::ocean_optics {
namespace {

[[noreturn]] void malformed(const std::string& device, const std::string& request, const std::string& what) {
  throw DeviceError(DeviceError::Kind::kProtocol, device, request, what);
}

std::string hex(std::uint8_t byte) {
  const char* digits = "0123456789abcdef";
  return std::string("0x") + digits[byte >> 4] + digits[byte & 0xF];
}

}  // namespace

std::vector<std::uint8_t> encode_initialize() { return {kInitialize}; }

std::vector<std::uint8_t> encode_set_integration_time(std::uint32_t us) {
  return {kSetIntegrationTime, static_cast<std::uint8_t>(us & 0xFF), static_cast<std::uint8_t>((us >> 8) & 0xFF),
          static_cast<std::uint8_t>((us >> 16) & 0xFF), static_cast<std::uint8_t>((us >> 24) & 0xFF)};
}

std::vector<std::uint8_t> encode_query_information(std::uint8_t slot) { return {kQueryInformation, slot}; }
std::vector<std::uint8_t> encode_request_spectrum() { return {kRequestSpectrum}; }
std::vector<std::uint8_t> encode_query_status() { return {kQueryStatus}; }

std::string parse_information_reply(std::span<const std::uint8_t> reply, std::uint8_t slot, const std::string& device) {
  std::string request = "query information slot " + std::to_string(slot);
  if (reply.size() != static_cast<std::size_t>(kInformationReplySize))
    malformed(device, request,
              "reply of " + std::to_string(reply.size()) + " bytes, expected " + std::to_string(kInformationReplySize));
  if (reply[0] != kQueryInformation) malformed(device, request, "reply starts with " + hex(reply[0]) + ", expected 0x05");
  if (reply[1] != slot) malformed(device, request, "reply is for slot " + std::to_string(reply[1]));
  std::string text;
  for (std::size_t i = 2; i < reply.size() && reply[i] != 0; ++i) {
    if (!std::isprint(reply[i])) malformed(device, request, "non-ASCII byte " + hex(reply[i]) + " in the slot text");
    text += static_cast<char>(reply[i]);
  }
  return text;
}

double parse_information_number(const std::string& text, std::uint8_t slot, const std::string& device) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  double value = std::strtod(begin, &end);
  while (end && *end == ' ') ++end;
  if (end == begin || errno == ERANGE || *end != '\0')
    malformed(device, "query information slot " + std::to_string(slot), "slot text '" + text + "' is not a number");
  return value;
}

SpectrometerStatus parse_status_reply(std::span<const std::uint8_t> reply, const std::string& device) {
  if (reply.size() != static_cast<std::size_t>(kStatusReplySize))
    malformed(device, "query status",
              "reply of " + std::to_string(reply.size()) + " bytes, expected " + std::to_string(kStatusReplySize));
  SpectrometerStatus status;
  status.pixel_count = reply[kStatusPixelCount] | reply[kStatusPixelCount + 1] << 8;
  const std::uint8_t* t = &reply[kStatusIntegrationTimeUs];
  status.integration_time_us = t[0] | t[1] << 8 | t[2] << 16 | std::uint32_t(t[3]) << 24;
  status.lamp_enabled = reply[kStatusLampEnable] != 0;
  status.data_ready = reply[kStatusAcquisitionStatus] != 0;
  if (status.pixel_count == 0) malformed(device, "query status", "pixel count 0");
  return status;
}

std::vector<double> parse_spectrum(std::span<const std::uint8_t> bytes, int pixel_count, const std::string& device) {
  std::size_t expected = 2 * static_cast<std::size_t>(pixel_count) + 1;
  if (bytes.size() != expected)
    malformed(device, "request spectrum",
              (bytes.size() < expected ? "short spectrum: " : "oversized spectrum: ") + std::to_string(bytes.size()) +
                  " bytes, expected " + std::to_string(expected));
  if (bytes.back() != kSpectrumSyncByte)
    malformed(device, "request spectrum", "sync byte " + hex(bytes.back()) + ", expected 0x69");
  std::vector<double> counts(pixel_count);
  for (int p = 0; p < pixel_count; ++p) counts[p] = bytes[2 * p] | bytes[2 * p + 1] << 8;
  return counts;
}

}  // namespace chromo::drivers::ocean_optics
