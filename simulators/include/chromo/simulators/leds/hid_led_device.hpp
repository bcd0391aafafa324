#pragma once
// HidLedDevice: the device side of the HID LED controller protocol
// (docs/protocols/led-hid.md), in-process behind the drivers' HidTransport
// seam. It parses each command report with its own parser (never the
// driver's), acts on the LedLab, and queues exactly one reply report, which
// read_report() hands out.
//
// While lab.unresponsive() commands are swallowed without a reply. Reply
// corruption can be injected to test the driver's parser over the seam.
// Lifetime: the LedLab must outlive the device. Thread rules: one thread at a
// time (as any HidTransport).

#include <deque>
#include <vector>

#include "chromo/drivers/led/hid_transport.hpp"
#include "chromo/simulators/leds/led_lab.hpp"

namespace chromo::simulators {

enum class HidReplyCorruption {
  kNone,
  kShort,          // the next reply is truncated to 10 bytes
  kOversized,      // the next reply is 65 bytes
  kWrongSequence,  // the next reply echoes another sequence number
  kBadLength,      // the next reply's payload length byte exceeds the report
};

class HidLedDevice final : public drivers::HidTransport {
 public:
  explicit HidLedDevice(LedLab& lab) : lab_(lab) {}
  void write_report(std::span<const std::uint8_t> report) override;
  std::size_t read_report(std::span<std::uint8_t> buffer, int timeout_ms) override;
  std::string describe() const override { return "simulated HID LED controller " + lab_.info().serial; }

  void corrupt_next_reply(HidReplyCorruption corruption) { corruption_ = corruption; }

 private:
  std::vector<std::uint8_t> handle(std::span<const std::uint8_t> report);

  LedLab& lab_;
  std::deque<std::vector<std::uint8_t>> replies_;
  HidReplyCorruption corruption_ = HidReplyCorruption::kNone;
  // Sequence being loaded by kSequenceBegin/kSequenceState.
  std::vector<drivers::LedState> loading_;
  std::vector<bool> loaded_;
  drivers::SequenceTrigger loading_trigger_ = drivers::SequenceTrigger::kHardwareRisingEdge;
};

}  // namespace chromo::simulators
