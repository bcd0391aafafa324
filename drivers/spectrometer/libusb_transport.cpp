// UsbTransport on libusb-1.0: find by vendor/product id, open, claim
// interface 0, libusb_bulk_transfer.

#include <libusb.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/spectrometer/usb_transport.hpp"

namespace chromo::drivers {
namespace {

using Kind = DeviceError::Kind;

struct ContextDeleter {
  void operator()(libusb_context* ctx) const { libusb_exit(ctx); }
};
using SharedContext = std::shared_ptr<libusb_context>;

class LibusbTransport final : public UsbTransport {
 public:
  LibusbTransport(SharedContext ctx, libusb_device_handle* handle, std::uint16_t product_id, std::string name)
      : ctx_(std::move(ctx)), handle_(handle), product_id_(product_id), name_(std::move(name)) {}
  ~LibusbTransport() override {
    libusb_release_interface(handle_, 0);
    libusb_close(handle_);
  }

  void bulk_write(std::uint8_t endpoint, std::span<const std::uint8_t> data, int timeout_ms) override {
    int transferred = 0;
    int rc = libusb_bulk_transfer(handle_, endpoint, const_cast<unsigned char*>(data.data()),
                                  static_cast<int>(data.size()), &transferred, static_cast<unsigned>(timeout_ms));
    if (rc != 0 || transferred != static_cast<int>(data.size()))
      fail(rc, "bulk write to endpoint " + std::to_string(endpoint));
  }

  std::size_t bulk_read(std::uint8_t endpoint, std::span<std::uint8_t> buffer, int timeout_ms) override {
    int transferred = 0;
    int rc = libusb_bulk_transfer(handle_, endpoint, buffer.data(), static_cast<int>(buffer.size()), &transferred,
                                  static_cast<unsigned>(timeout_ms));
    if (rc == LIBUSB_ERROR_TIMEOUT && transferred > 0) return static_cast<std::size_t>(transferred);
    if (rc != 0) fail(rc, "bulk read from endpoint " + std::to_string(endpoint));
    return static_cast<std::size_t>(transferred);
  }

  std::uint16_t product_id() const override { return product_id_; }
  std::string describe() const override { return name_; }

 private:
  [[noreturn]] void fail(int rc, const std::string& request) const {
    Kind kind = rc == LIBUSB_ERROR_TIMEOUT    ? Kind::kTimeout
                : rc == LIBUSB_ERROR_NO_DEVICE ? Kind::kDisconnected
                                               : Kind::kProtocol;
    throw DeviceError(kind, name_, request, libusb_error_name(rc));
  }

  SharedContext ctx_;
  libusb_device_handle* handle_;
  std::uint16_t product_id_;
  std::string name_;
};

}  // namespace

std::vector<std::unique_ptr<UsbTransport>> open_libusb_transports(std::uint16_t vendor_id, std::uint16_t product_id) {
  libusb_context* raw = nullptr;
  if (int rc = libusb_init(&raw); rc != 0)
    throw DeviceError(Kind::kNotFound, "libusb", "initialise", libusb_error_name(rc));
  SharedContext ctx(raw, ContextDeleter{});
  libusb_device** list = nullptr;
  ssize_t count = libusb_get_device_list(ctx.get(), &list);
  std::vector<std::unique_ptr<UsbTransport>> transports;
  std::string errors;
  for (ssize_t i = 0; i < count; ++i) {
    libusb_device_descriptor descriptor{};
    if (libusb_get_device_descriptor(list[i], &descriptor) != 0) continue;
    if (descriptor.idVendor != vendor_id || descriptor.idProduct != product_id) continue;
    char name[80];
    std::snprintf(name, sizeof name, "USB %04x:%04x bus %u address %u", vendor_id, product_id,
                  libusb_get_bus_number(list[i]), libusb_get_device_address(list[i]));
    libusb_device_handle* handle = nullptr;
    if (int rc = libusb_open(list[i], &handle); rc != 0) {
      errors += std::string(name) + ": open: " + libusb_error_name(rc) + "; ";
      continue;
    }
    libusb_set_auto_detach_kernel_driver(handle, 1);
    if (int rc = libusb_claim_interface(handle, 0); rc != 0) {
      errors += std::string(name) + ": claim interface 0: " + libusb_error_name(rc) + "; ";
      libusb_close(handle);
      continue;
    }
    transports.push_back(std::make_unique<LibusbTransport>(ctx, handle, product_id, name));
  }
  if (list) libusb_free_device_list(list, 1);
  if (transports.empty() && !errors.empty())
    throw DeviceError(Kind::kNotFound, "libusb", "open devices", errors);
  return transports;
}

}  // namespace chromo::drivers
