#pragma once
// UsbSpectrometerDevice: a simulated Ocean Optics USB2000+ behind the
// drivers' UsbTransport seam. It parses the command bytes itself (never the
// driver's code), keeps the EEPROM slots (serial, wavelength calibration,
// non-linearity) and measures a SphereIllumination through a DetectorModel.
// Spectra come back as 8 × 512-byte packets and a 1-byte packet holding the
// sync byte 0x69, as on a USB2000+ at high speed.
//
// Real-unit behaviours it reproduces: the first spectrum after an
// integration-time change is integrated with the previous time (stale);
// counts saturate at 65535. It does not sleep for the integration time.
//
// Faults on demand: stop answering (reads time out), short / oversized /
// bad-sync spectrum transfers, short/oversized query replies, and a
// saturating overload (signal × 1000). Unknown or malformed commands are
// ignored, as the device does, and counted.
//
// Lifetime: the SphereIllumination must outlive the device. Thread rules:
// one thread at a time (as any UsbTransport); it reads the illumination,
// which is thread-safe.

#include <deque>
#include <map>
#include <random>
#include <vector>

#include "chromo/drivers/spectrometer/usb_transport.hpp"
#include "chromo/simulators/spectrometer/detector_model.hpp"
#include "chromo/simulators/sphere_illumination.hpp"

namespace chromo::simulators {

enum class SpectrometerFault {
  kNone,
  kUnresponsive,       // commands are accepted, nothing is ever answered
  kShortSpectrum,      // the transfer ends after 3 packets
  kOversizedSpectrum,  // a full 512-byte packet where the 1-byte sync packet belongs
  kBadSyncByte,        // 0x00 instead of 0x69
  kShortReply,         // information/status replies lose their last byte
  kOversizedReply,     // information/status replies carry an extra byte
  kOverload,           // the detector sees 1000 × the light: saturates at any time
};

class UsbSpectrometerDevice final : public drivers::UsbTransport {
 public:
  UsbSpectrometerDevice(const SphereIllumination& light, DetectorModel model = {});

  void bulk_write(std::uint8_t endpoint, std::span<const std::uint8_t> data, int timeout_ms) override;
  std::size_t bulk_read(std::uint8_t endpoint, std::span<std::uint8_t> buffer, int timeout_ms) override;
  std::uint16_t product_id() const override;
  std::string describe() const override { return "simulated USB2000+ " + model_.serial; }

  void set_fault(SpectrometerFault fault) { fault_ = fault; }
  const DetectorModel& model() const { return model_; }
  std::uint32_t integration_time_us() const { return integration_time_us_; }
  int spectra_sent() const { return spectra_sent_; }
  int ignored_commands() const { return ignored_commands_; }

 private:
  std::vector<double> expose(std::uint32_t integration_time_us);
  void queue_reply(std::vector<std::uint8_t> reply);
  std::vector<std::uint8_t> slot_text(std::uint8_t slot) const;

  const SphereIllumination& light_;
  DetectorModel model_;
  std::map<std::uint8_t, std::string> eeprom_;
  std::uint32_t integration_time_us_ = 100000;
  std::uint32_t stale_time_us_ = 0;  // non-zero: the next spectrum integrates with this time
  std::deque<std::vector<std::uint8_t>> query_replies_, spectrum_packets_;
  SpectrometerFault fault_ = SpectrometerFault::kNone;
  std::mt19937_64 rng_;
  int spectra_sent_ = 0;
  int ignored_commands_ = 0;
};

}  // namespace chromo::simulators
