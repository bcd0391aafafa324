#pragma once
// ModbusLedServer: the LED simulator's Modbus front-end, libmodbus' server
// side, serving a LedLab with the register map of docs/protocols/led-modbus.md.
//
// - TCP: listens on address:port (port 0 = any free port; port() tells which),
//   serves any number of clients, one request at a time.
// - RTU: opens a pseudo-terminal pair (posix_openpt/grantpt/unlockpt/ptsname)
//   and answers on the master side; a driver opens device_path() (the slave
//   side) with modbus_new_rtu. Baud rate and framing are whatever the driver
//   sets (a pty ignores them).
//
// While lab.unresponsive() the server receives requests and drops them (the
// driver must time out). Lifetime: serving starts in the factory and stops in
// the destructor (which joins the thread); the LedLab must outlive the server.
// Thread rules: the accessors may be called from any thread.

#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "chromo/simulators/leds/led_lab.hpp"

namespace chromo::simulators {

class ModbusLedServer {
 public:
  static std::unique_ptr<ModbusLedServer> start_tcp(LedLab& lab, int port = 0, int unit_id = 1,
                                                    const std::string& address = "127.0.0.1");
  static std::unique_ptr<ModbusLedServer> start_rtu(LedLab& lab, int unit_id = 1);
  ~ModbusLedServer();
  ModbusLedServer(const ModbusLedServer&) = delete;
  ModbusLedServer& operator=(const ModbusLedServer&) = delete;

  int port() const { return port_; }                         // TCP; 0 for RTU
  const std::string& device_path() const { return device_path_; }  // RTU; empty for TCP
  // "tcp://127.0.0.1:50123" or "rtu:///dev/pts/7", for logs.
  std::string address() const;
  int unit_id() const { return unit_id_; }
  long requests_answered() const { return answered_.load(); }
  long requests_dropped() const { return dropped_.load(); }

 private:
  struct Impl;
  explicit ModbusLedServer(LedLab& lab);
  void serve_tcp();
  void serve_rtu();
  void handle_request(const unsigned char* query, int length);

  LedLab& lab_;
  std::unique_ptr<Impl> impl_;
  int port_ = 0;
  int unit_id_ = 1;
  std::string host_;
  std::string device_path_;
  std::atomic<long> answered_{0}, dropped_{0};
  std::thread thread_;
};

}  // namespace chromo::simulators
