// HidTransport on hidapi (hidraw backend): hid_open by VID/PID/serial,
// hid_write, hid_read_timeout. Numbered reports: byte 0 is the report id in
// both directions.

#include <hidapi/hidapi.h>

#include <cstdio>
#include <string>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led/hid_transport.hpp"

namespace chromo::drivers {
namespace {

using Kind = DeviceError::Kind;

std::string narrow(const wchar_t* text) {
  std::string out;
  for (; text && *text; ++text) out += *text < 128 ? static_cast<char>(*text) : '?';
  return out;
}

class HidapiTransport final : public HidTransport {
 public:
  HidapiTransport(hid_device* device, std::string name) : device_(device), name_(std::move(name)) {}
  ~HidapiTransport() override { hid_close(device_); }

  void write_report(std::span<const std::uint8_t> report) override {
    int n = hid_write(device_, report.data(), report.size());
    if (n < 0) throw DeviceError(Kind::kDisconnected, name_, "hid_write", narrow(hid_error(device_)));
  }

  std::size_t read_report(std::span<std::uint8_t> buffer, int timeout_ms) override {
    int n = hid_read_timeout(device_, buffer.data(), buffer.size(), timeout_ms);
    if (n < 0) throw DeviceError(Kind::kDisconnected, name_, "hid_read_timeout", narrow(hid_error(device_)));
    return static_cast<std::size_t>(n);
  }

  std::string describe() const override { return name_; }

 private:
  hid_device* device_;
  std::string name_;
};

}  // namespace

std::unique_ptr<HidTransport> open_hidapi_transport(std::uint16_t vendor_id, std::uint16_t product_id,
                                                    const std::string& serial) {
  char name[96];
  std::snprintf(name, sizeof name, "hidapi %04x:%04x%s%s", vendor_id, product_id, serial.empty() ? "" : " serial ",
                serial.c_str());
  if (hid_init() != 0) throw DeviceError(Kind::kNotFound, name, "hid_init", "failed");
  std::wstring wide(serial.begin(), serial.end());
  hid_device* device = hid_open(vendor_id, product_id, serial.empty() ? nullptr : wide.c_str());
  if (!device) throw DeviceError(Kind::kNotFound, name, "hid_open", "no such HID device (or no permission)");
  return std::make_unique<HidapiTransport>(device, name);
}

}  // namespace chromo::drivers
