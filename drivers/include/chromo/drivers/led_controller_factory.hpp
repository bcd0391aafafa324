#pragma once
// Creating LED controllers from configuration: the real backends and, through
// the same functions, the simulators (which listen on real TCP ports and ptys,
// or sit behind the HID seam).
//
// Every factory connects, reads the device's information and returns a ready
// controller, or throws DeviceError (kNotFound, kTimeout, kProtocol).

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "chromo/drivers/led/hid_transport.hpp"
#include "chromo/drivers/led_controller.hpp"

namespace chromo::drivers {

struct ModbusLinkOptions {
  int unit_id = 1;
  std::chrono::milliseconds response_timeout{300};  // a silent device gives kTimeout after this
};

// Modbus TCP (docs/protocols/led-modbus.md).
std::unique_ptr<LedController> make_modbus_tcp_led_controller(const std::string& host, int port,
                                                              ModbusLinkOptions options = {});
// Modbus RTU on a serial device (e.g. /dev/ttyUSB0 or the simulator's pty), 8N1.
std::unique_ptr<LedController> make_modbus_rtu_led_controller(const std::string& device_path, int baud,
                                                              ModbusLinkOptions options = {});

struct HidLinkOptions {
  std::chrono::milliseconds reply_timeout{300};
};
// USB HID through hidapi (docs/protocols/led-hid.md). Empty serial: the first match.
std::unique_ptr<LedController> make_hid_led_controller(std::uint16_t vendor_id, std::uint16_t product_id,
                                                       const std::string& serial, HidLinkOptions options = {});
// Over any HID transport (the simulator's, in tests and chromo-sim).
std::unique_ptr<LedController> make_hid_led_controller(std::unique_ptr<HidTransport> transport,
                                                       HidLinkOptions options = {});

}  // namespace chromo::drivers
