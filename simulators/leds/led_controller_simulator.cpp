#include "chromo/simulators/leds/led_controller_simulator.hpp"

namespace chromo::simulators {

LedControllerSimulator::LedControllerSimulator(LedLabOptions options)
    : lab_(std::make_unique<LedLab>(std::move(options))) {}

LedControllerSimulator::~LedControllerSimulator() {
  tcp_.reset();
  rtu_.reset();
}

int LedControllerSimulator::start_modbus_tcp(int port, int unit_id, const std::string& address) {
  tcp_ = ModbusLedServer::start_tcp(*lab_, port, unit_id, address);
  return tcp_->port();
}

std::string LedControllerSimulator::start_modbus_rtu(int unit_id) {
  rtu_ = ModbusLedServer::start_rtu(*lab_, unit_id);
  return rtu_->device_path();
}

void LedControllerSimulator::stop_modbus_tcp() { tcp_.reset(); }
void LedControllerSimulator::stop_modbus_rtu() { rtu_.reset(); }

std::unique_ptr<HidLedDevice> LedControllerSimulator::make_hid_transport() {
  return std::make_unique<HidLedDevice>(*lab_);
}

}  // namespace chromo::simulators
