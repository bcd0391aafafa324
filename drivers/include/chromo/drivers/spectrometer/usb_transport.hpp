#pragma once
// UsbTransport: the seam between the spectrometer driver and the device, at
// raw USB bulk transfers. The real one is libusb-1.0 (libusb_bulk_transfer on
// a claimed interface); the simulator implements the same seam in-process
// (simulators/spectrometer/usb_spectrometer_device.hpp).
//
// Thread rules: one thread at a time. Lifetime: the transport owns its handle.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace chromo::drivers {

class UsbTransport {
 public:
  virtual ~UsbTransport() = default;
  // One bulk OUT transfer of all of `data`. Throws DeviceError (kTimeout,
  // kDisconnected) if it cannot be sent.
  virtual void bulk_write(std::uint8_t endpoint, std::span<const std::uint8_t> data, int timeout_ms) = 0;
  // One bulk IN transfer into `buffer` (ends at a short packet or a full
  // buffer). Returns the bytes received (≥ 1). Throws DeviceError(kTimeout)
  // when nothing arrived in time, kProtocol if the device sent more than fits
  // (overflow), kDisconnected when the device is gone.
  virtual std::size_t bulk_read(std::uint8_t endpoint, std::span<std::uint8_t> buffer, int timeout_ms) = 0;
  virtual std::uint16_t product_id() const = 0;
  virtual std::string describe() const = 0;  // "USB 2457:101e bus 1 address 4", for messages
};

// libusb: every attached device with this vendor/product id, opened, with
// interface 0 claimed. Empty if there is none.
std::vector<std::unique_ptr<UsbTransport>> open_libusb_transports(std::uint16_t vendor_id, std::uint16_t product_id);

}  // namespace chromo::drivers
