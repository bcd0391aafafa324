#pragma once
// HidTransport: the seam between the HID LED controller driver and the device,
// at raw report bytes. The real one wraps hidapi (hid_open by VID/PID/serial,
// hid_write, hid_read_timeout); the simulator's device side implements the
// same seam in-process (simulators/leds/hid_led_device.hpp).
//
// Thread rules: one thread at a time. Lifetime: the transport owns its handle.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

namespace chromo::drivers {

class HidTransport {
 public:
  virtual ~HidTransport() = default;
  // Sends one report; byte 0 is the report id. Throws DeviceError (kDisconnected).
  virtual void write_report(std::span<const std::uint8_t> report) = 0;
  // Waits up to timeout_ms for one input report and copies it (report id first)
  // into `buffer`. Returns the number of bytes; 0 means nothing arrived in time.
  // Throws DeviceError (kDisconnected) when the link is gone.
  virtual std::size_t read_report(std::span<std::uint8_t> buffer, int timeout_ms) = 0;
  // "hidapi 0001:0002 serial X", for messages.
  virtual std::string describe() const = 0;
};

// hidapi: opens the first device with this vendor/product id (and serial, if
// not empty). Throws DeviceError(kNotFound) if there is none.
std::unique_ptr<HidTransport> open_hidapi_transport(std::uint16_t vendor_id, std::uint16_t product_id,
                                                    const std::string& serial);

}  // namespace chromo::drivers
