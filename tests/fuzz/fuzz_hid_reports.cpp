// The LED controller's USB HID replies (drivers/led/hid_reports.hpp,
// docs/protocols): a 64-byte input report, then its info or status payload.
// Documented error: drivers::DeviceError.
#include <cstdint>
#include <span>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led/hid_reports.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace hr = chromo::drivers::hid_reports;
  const std::span<const std::uint8_t> bytes(data, size);
  try {
    const hr::Reply reply = hr::parse_reply(bytes, "fuzz");
    (void)hr::status_name(reply.status);
    try {
      (void)hr::parse_info_payload(reply.payload, "fuzz");
    } catch (const chromo::drivers::DeviceError&) {
    }
    (void)hr::parse_status_payload(reply.payload, "fuzz");
  } catch (const chromo::drivers::DeviceError&) {
  }
  // The payload parsers on raw bytes too (they are called on any reply's payload).
  try {
    (void)hr::parse_info_payload(bytes, "fuzz");
  } catch (const chromo::drivers::DeviceError&) {
  }
  try {
    (void)hr::parse_status_payload(bytes, "fuzz");
  } catch (const chromo::drivers::DeviceError&) {
  }
  return 0;
}
