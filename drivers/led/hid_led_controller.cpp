// LED controller over USB HID reports (docs/protocols/led-hid.md): one
// command report, one reply report with the same sequence number.

#include <algorithm>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led/hid_reports.hpp"
#include "chromo/drivers/led/led_hid_protocol.hpp"
#include "chromo/drivers/led_controller_factory.hpp"
#include "led_state_rules.hpp"

namespace chromo::drivers {
namespace {

namespace hid = led_hid;
using Kind = DeviceError::Kind;

class HidLedController final : public LedController {
 public:
  HidLedController(std::unique_ptr<HidTransport> transport, HidLinkOptions options)
      : transport_(std::move(transport)), options_(options), device_("HID LED controller " + transport_->describe()) {
    info_ = hid_reports::parse_info_payload(transact(hid::kGetInfo, {}, "read info"), device_);
    device_ = "HID LED controller " + info_.serial + " (" + transport_->describe() + ")";
  }

  LedControllerInfo info() const override { return info_; }

  void set_state(const LedState& state) override {
    detail::validate_state(state, info_, device_);
    transact(hid::kSetState, hid_reports::encode_state_payload(state, info_.has_polarisers()), "set state");
    detail::check_applied_state(state, read_status(), device_);
  }

  LedStatus read_status() override {
    return hid_reports::parse_status_payload(transact(hid::kGetStatus, {}, "read status"), device_);
  }

  void set_output_enabled(bool enabled) override {
    std::uint8_t on = enabled ? 1 : 0;
    transact(hid::kSetOutput, {&on, 1}, enabled ? "enable output" : "disable output");
  }

  void arm_sequence(std::span<const LedState> states, SequenceTrigger trigger) override {
    detail::validate_sequence(states, info_, device_);
    auto count = static_cast<std::uint16_t>(states.size());
    std::vector<std::uint8_t> begin{static_cast<std::uint8_t>(count & 0xFF), static_cast<std::uint8_t>(count >> 8),
                                    trigger_code(trigger)};
    transact(hid::kSequenceBegin, begin, "begin sequence");
    for (std::uint16_t k = 0; k < count; ++k) {
      std::vector<std::uint8_t> payload{static_cast<std::uint8_t>(k & 0xFF), static_cast<std::uint8_t>(k >> 8)};
      std::vector<std::uint8_t> state = hid_reports::encode_state_payload(states[k], info_.has_polarisers());
      payload.insert(payload.end(), state.begin(), state.end());
      transact(hid::kSequenceState, payload, "load sequence state " + std::to_string(k));
    }
    transact(hid::kSequenceArm, {}, "arm sequence");
  }

  void advance_sequence() override { transact(hid::kSequenceAdvance, {}, "advance sequence"); }
  void disarm_sequence() override { transact(hid::kSequenceDisarm, {}, "disarm sequence"); }

  std::uint32_t fire_trigger(std::uint32_t pulse_width_us) override {
    detail::validate_trigger_pulse(pulse_width_us, device_);
    const std::uint8_t width[hid::kFireTriggerPayloadSize] = {static_cast<std::uint8_t>(pulse_width_us & 0xFF),
                                                              static_cast<std::uint8_t>(pulse_width_us >> 8)};
    return hid_reports::parse_fire_trigger_payload(transact(hid::kFireTrigger, width, "fire trigger"), device_);
  }

 private:
  static std::uint8_t trigger_code(SequenceTrigger trigger) {
    switch (trigger) {
      case SequenceTrigger::kHardwareRisingEdge: return hid::kTriggerHardwareEdge;
      case SequenceTrigger::kSoftware: return hid::kTriggerSoftware;
      case SequenceTrigger::kTriggerOutput: return hid::kTriggerOwnOutput;
    }
    return hid::kTriggerHardwareEdge;
  }

  // Sends one command and returns the payload of its reply. Replies to
  // earlier commands that timed out are recognised by their sequence number
  // and skipped; anything else out of sequence is a protocol error.
  std::vector<std::uint8_t> transact(std::uint8_t command, std::span<const std::uint8_t> payload,
                                     const std::string& request) {
    const std::uint8_t sequence = ++sequence_;
    try {
      transport_->write_report(hid_reports::encode_command(sequence, command, payload));
    } catch (const DeviceError& e) {
      throw DeviceError(e.kind(), device_, request, e.answer());
    }
    std::vector<std::uint8_t> buffer(2 * hid::kReportSize);  // room to see an oversized report
    for (;;) {
      std::size_t n = transport_->read_report(buffer, static_cast<int>(options_.reply_timeout.count()));
      if (n == 0) {
        timed_out_.push_back(sequence);
        if (timed_out_.size() > 16) timed_out_.pop_front();
        throw DeviceError(Kind::kTimeout, device_, request,
                          "no reply within " + std::to_string(options_.reply_timeout.count()) + " ms");
      }
      hid_reports::Reply reply = hid_reports::parse_reply(std::span(buffer.data(), n), device_);
      if (reply.sequence != sequence) {
        if (std::find(timed_out_.begin(), timed_out_.end(), reply.sequence) != timed_out_.end()) continue;
        throw DeviceError(Kind::kProtocol, device_, request,
                          "reply with sequence " + std::to_string(reply.sequence) + ", expected " +
                              std::to_string(sequence));
      }
      if (reply.command != command)
        throw DeviceError(Kind::kProtocol, device_, request,
                          "reply echoes command " + std::to_string(reply.command) + ", expected " +
                              std::to_string(command));
      if (reply.status == hid::kFault) {
        std::uint32_t faults = hid_reports::parse_status_payload(transact(hid::kGetStatus, {}, "read status"), device_)
                                   .controller_faults;
        throw DeviceError(Kind::kFault, device_, request,
                          "refused: controller fault " + detail::describe_faults(faults));
      }
      if (reply.status != hid::kOk)
        throw DeviceError(Kind::kRefused, device_, request, "refused: " + hid_reports::status_name(reply.status));
      return reply.payload;
    }
  }

  std::unique_ptr<HidTransport> transport_;
  HidLinkOptions options_;
  std::string device_;
  LedControllerInfo info_;
  std::uint8_t sequence_ = 0;
  std::deque<std::uint8_t> timed_out_;
};

}  // namespace

std::unique_ptr<LedController> make_hid_led_controller(std::unique_ptr<HidTransport> transport,
                                                       HidLinkOptions options) {
  return std::make_unique<HidLedController>(std::move(transport), options);
}

std::unique_ptr<LedController> make_hid_led_controller(std::uint16_t vendor_id, std::uint16_t product_id,
                                                       const std::string& serial, HidLinkOptions options) {
  return make_hid_led_controller(open_hidapi_transport(vendor_id, product_id, serial), options);
}

}  // namespace chromo::drivers
