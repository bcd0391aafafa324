// The USB2000+/Flame driver: the Ocean Optics command set over a UsbTransport.

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/spectrometer/ocean_optics_messages.hpp"
#include "chromo/drivers/spectrometer/ocean_optics_protocol.hpp"
#include "chromo/drivers/spectrometer_factory.hpp"

namespace chromo::drivers {
namespace {

namespace oo = ocean_optics;
using Kind = DeviceError::Kind;

constexpr int kQueryTimeoutMs = 1000;

class OceanSpectrometer final : public Spectrometer {
 public:
  explicit OceanSpectrometer(std::unique_ptr<UsbTransport> transport)
      : transport_(std::move(transport)), device_(transport_->describe()) {
    send(oo::encode_initialize(), "initialise");
    info_.model = transport_->product_id() == oo::kProductIdUsb2000Plus ? "USB2000+" : "Ocean Optics (OOI protocol)";
    info_.serial = read_slot(oo::kSlotSerialNumber);
    device_ = "spectrometer " + info_.model + " " + info_.serial + " (" + transport_->describe() + ")";
    for (int i = 0; i < 4; ++i)
      info_.wavelength_coefficients[i] = read_number(static_cast<std::uint8_t>(oo::kSlotWavelengthCoefficient0 + i));
    double order = read_number(oo::kSlotNonlinearityOrder);
    if (order < 0 || order > oo::kMaxNonlinearityOrder || order != static_cast<int>(order))
      throw DeviceError(Kind::kProtocol, device_, "query information slot 14",
                        "non-linearity order " + std::to_string(order) + " outside 0-7");
    for (int i = 0; i <= static_cast<int>(order); ++i)
      info_.nonlinearity_coefficients.push_back(
          read_number(static_cast<std::uint8_t>(oo::kSlotNonlinearityCoefficient0 + i)));
    SpectrometerStatus status = read_status();
    info_.pixel_count = status.pixel_count;
    integration_time_us_ = status.integration_time_us;
    info_.saturation_counts = oo::kUsb2000PlusSaturationCounts;
    info_.min_integration_time_us = oo::kUsb2000PlusMinIntegrationUs;
    info_.max_integration_time_us = oo::kUsb2000PlusMaxIntegrationUs;
  }

  SpectrometerInfo info() const override { return info_; }

  void set_integration_time_us(std::uint32_t us) override {
    if (us < info_.min_integration_time_us || us > info_.max_integration_time_us)
      throw DeviceError(Kind::kInvalidRequest, device_, "set integration time " + std::to_string(us) + " us",
                        "outside [" + std::to_string(info_.min_integration_time_us) + ", " +
                            std::to_string(info_.max_integration_time_us) + "] us");
    send(oo::encode_set_integration_time(us), "set integration time");
    integration_time_us_ = us;
  }

  RawSpectrum read_raw_spectrum() override {
    send(oo::encode_request_spectrum(), "request spectrum");
    const std::size_t expected = 2 * static_cast<std::size_t>(info_.pixel_count) + 1;
    int timeout_ms = static_cast<int>(std::min<std::uint64_t>(integration_time_us_ / 1000 + 1000, 1u << 30));
    std::vector<std::uint8_t> bytes;
    std::vector<std::uint8_t> packet(oo::kSpectrumPacketSize);
    while (bytes.size() < expected) {
      std::size_t n = transport_->bulk_read(oo::kEndpointSpectrumIn, packet, timeout_ms);
      std::size_t remaining = expected - bytes.size();
      if (n > remaining) {
        drain();
        throw DeviceError(Kind::kProtocol, device_, "request spectrum",
                          "oversized spectrum: a " + std::to_string(n) + "-byte packet where " +
                              std::to_string(remaining) + " bytes were left");
      }
      bytes.insert(bytes.end(), packet.begin(), packet.begin() + static_cast<std::ptrdiff_t>(n));
      if (n < packet.size() && bytes.size() < expected)  // a short packet ends the transfer early
        throw DeviceError(Kind::kProtocol, device_, "request spectrum",
                          "short spectrum: transfer ended after " + std::to_string(bytes.size()) + " of " +
                              std::to_string(expected) + " bytes");
    }
    return RawSpectrum{oo::parse_spectrum(bytes, info_.pixel_count, device_), integration_time_us_};
  }

  SpectrometerStatus read_status() override {
    send(oo::encode_query_status(), "query status");
    std::vector<std::uint8_t> reply = query_reply(oo::kStatusReplySize, "query status");
    return oo::parse_status_reply(reply, device_);
  }

 private:
  void send(const std::vector<std::uint8_t>& command, const std::string& request) {
    try {
      transport_->bulk_write(oo::kEndpointCommandOut, command, kQueryTimeoutMs);
    } catch (const DeviceError& e) {
      throw DeviceError(e.kind(), device_, request, e.answer());
    }
  }

  // One transfer from EP1 in, with room for one byte more than expected so an
  // oversized reply is seen as such.
  std::vector<std::uint8_t> query_reply(int expected_size, const std::string& request) {
    std::vector<std::uint8_t> reply(static_cast<std::size_t>(expected_size) + 1);
    try {
      reply.resize(transport_->bulk_read(oo::kEndpointQueryIn, reply, kQueryTimeoutMs));
    } catch (const DeviceError& e) {
      throw DeviceError(e.kind(), device_, request, e.answer());
    }
    return reply;
  }

  std::string read_slot(std::uint8_t slot) {
    std::string request = "query information slot " + std::to_string(slot);
    send(oo::encode_query_information(slot), request);
    return oo::parse_information_reply(query_reply(oo::kInformationReplySize, request), slot, device_);
  }

  double read_number(std::uint8_t slot) { return oo::parse_information_number(read_slot(slot), slot, device_); }

  // After a broken transfer: discard whatever the device still has queued.
  void drain() {
    std::vector<std::uint8_t> packet(oo::kSpectrumPacketSize);
    try {
      for (int i = 0; i < 64; ++i) transport_->bulk_read(oo::kEndpointSpectrumIn, packet, 20);
    } catch (const DeviceError&) {
    }
  }

  std::unique_ptr<UsbTransport> transport_;
  std::string device_;
  SpectrometerInfo info_;
  std::uint32_t integration_time_us_ = 0;
};

}  // namespace

std::unique_ptr<Spectrometer> make_usb_spectrometer(std::unique_ptr<UsbTransport> transport) {
  return std::make_unique<OceanSpectrometer>(std::move(transport));
}

std::unique_ptr<Spectrometer> make_usb_spectrometer(const std::string& serial) {
  auto transports = open_libusb_transports(ocean_optics::kVendorId, ocean_optics::kProductIdUsb2000Plus);
  std::string wanted = serial.empty() ? "any serial" : "serial " + serial;
  if (transports.empty())
    throw DeviceError(Kind::kNotFound, "USB2000+ spectrometer", "find USB 2457:101e with " + wanted,
                      "no such device attached");
  if (serial.empty()) {
    if (transports.size() > 1)
      throw DeviceError(Kind::kNotFound, "USB2000+ spectrometer", "find USB 2457:101e",
                        std::to_string(transports.size()) + " attached: give a serial number");
    return make_usb_spectrometer(std::move(transports.front()));
  }
  std::string seen;
  for (auto& transport : transports) {
    auto spectrometer = make_usb_spectrometer(std::move(transport));
    if (spectrometer->info().serial == serial) return spectrometer;
    seen += (seen.empty() ? "" : ", ") + spectrometer->info().serial;
  }
  throw DeviceError(Kind::kNotFound, "USB2000+ spectrometer", "find USB 2457:101e with " + wanted,
                    "attached serials: " + seen);
}

}  // namespace chromo::drivers
