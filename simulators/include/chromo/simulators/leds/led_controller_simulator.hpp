#pragma once
// LedControllerSimulator: the simulated LED controller as one object, for
// tests, chromo-sim and the daemon's simulated configuration. It owns the
// LedLab (firmware state + physical truth, a SphereIllumination) and starts
// the front-ends it is asked for, each with a single call:
//
//   LedControllerSimulator sim;                 // lab with default options
//   int port = sim.start_modbus_tcp();          // 127.0.0.1:<port>, any free port by default
//   std::string tty = sim.start_modbus_rtu();   // e.g. "/dev/pts/7": open with modbus_new_rtu
//   auto transport = sim.make_hid_transport();  // HID device side behind the seam
//   auto led = drivers::make_modbus_tcp_led_controller("127.0.0.1", port);
//
// trigger() is the hardware trigger input (call it on the camera's
// exposure-active edge). Lifetime: stopping happens in the destructor (or
// stop_modbus_*); HID transports made here must not outlive the simulator.
// Thread rules: start/stop from one thread; lab() and trigger() from any.

#include <memory>
#include <string>

#include "chromo/drivers/led/hid_transport.hpp"
#include "chromo/simulators/leds/hid_led_device.hpp"
#include "chromo/simulators/leds/led_lab.hpp"
#include "chromo/simulators/leds/modbus_led_server.hpp"

namespace chromo::simulators {

class LedControllerSimulator {
 public:
  explicit LedControllerSimulator(LedLabOptions options = {});
  ~LedControllerSimulator();

  // Returns the TCP port listened on (127.0.0.1 unless `address` says otherwise).
  int start_modbus_tcp(int port = 0, int unit_id = 1, const std::string& address = "127.0.0.1");
  // Returns the pty slave path a driver opens.
  std::string start_modbus_rtu(int unit_id = 1);
  void stop_modbus_tcp();
  void stop_modbus_rtu();
  const ModbusLedServer* modbus_tcp() const { return tcp_.get(); }
  const ModbusLedServer* modbus_rtu() const { return rtu_.get(); }
  std::unique_ptr<HidLedDevice> make_hid_transport();

  LedLab& lab() { return *lab_; }
  const LedLab& lab() const { return *lab_; }
  void trigger() { lab_->trigger(); }

 private:
  std::unique_ptr<LedLab> lab_;
  std::unique_ptr<ModbusLedServer> tcp_, rtu_;
};

}  // namespace chromo::simulators
