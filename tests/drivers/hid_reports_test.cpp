// The HID report protocol, driver side: golden bytes from
// docs/protocols/led-hid.md, the parser's rejection of bad reports, and bad
// replies arriving over the seam from the simulator.

#include <gtest/gtest.h>

#include <functional>
#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led/hid_reports.hpp"
#include "chromo/drivers/led_controller_factory.hpp"
#include "chromo/simulators/leds/led_controller_simulator.hpp"

namespace chromo {
namespace {

using drivers::DeviceError;
using Bytes = std::vector<std::uint8_t>;
namespace hr = drivers::hid_reports;

DeviceError::Kind kind_of(const std::function<void()>& f, std::string* message = nullptr) {
  try {
    f();
  } catch (const DeviceError& e) {
    if (message) *message = e.what();
    return e.kind();
  }
  ADD_FAILURE() << "no DeviceError";
  return DeviceError::Kind::kNotFound;
}

Bytes reply_report(std::initializer_list<std::uint8_t> head) {
  Bytes report(64, 0);
  std::copy(head.begin(), head.end(), report.begin());
  return report;
}

TEST(HidReports, SetStateCommandMatchesTheDocumentedLayout) {
  drivers::LedState state;
  state.drive = {1.0, 0.5, 0, 0, 0, 0};
  state.pwm_frequency_hz = 1000;
  state.zone = 2;
  Bytes report = hr::encode_command(0x2A, 0x02, hr::encode_state_payload(state, false));
  // docs/protocols/led-hid.md, "Example": id, seq, command, length 17, zone,
  // 1000 Hz = E8 03 00 00, W57 = FF FF, W40 = 80 00 (32768), rest zero.
  Bytes expected = reply_report({0x01, 0x2A, 0x02, 17, 0x02, 0xE8, 0x03, 0x00, 0x00, 0xFF, 0xFF, 0x00, 0x80});
  EXPECT_EQ(report, expected);
}

TEST(HidReports, PolarisedStateStatusAndInfoFollowTheDocumentedLayout) {
  drivers::LedState state;
  state.polarisation[0] = drivers::Polarisation::kCross;     // W57: bits 0-1 = 1
  state.polarisation[5] = drivers::Polarisation::kParallel;  // B: bits 10-11 = 2
  const Bytes plain = hr::encode_state_payload(state, false);
  const Bytes polarised = hr::encode_state_payload(state, true);
  ASSERT_EQ(plain.size(), 17u);
  ASSERT_EQ(polarised.size(), 19u);
  EXPECT_EQ(Bytes(polarised.begin(), polarised.begin() + 17), plain);
  EXPECT_EQ(polarised[17], 0x01);
  EXPECT_EQ(polarised[18], 0x08);

  Bytes status(46, 0);
  status[44] = 0x01, status[45] = 0x08;
  EXPECT_EQ(hr::parse_status_payload(status, "dev").applied.polarisation, state.polarisation);
  EXPECT_EQ(hr::parse_status_payload(Bytes(44, 0), "dev").applied.polarisation, drivers::PolarisationPerType{});
  std::string message;
  status[45] = 0x10;  // bit 12
  EXPECT_EQ(kind_of([&] { hr::parse_status_payload(status, "dev"); }, &message), DeviceError::Kind::kProtocol);
  EXPECT_NE(message.find("bytes 44-45"), std::string::npos) << message;
  EXPECT_EQ(kind_of([&] { hr::parse_status_payload(Bytes(45, 0), "dev"); }, &message), DeviceError::Kind::kProtocol);
  EXPECT_NE(message.find("expected 44 or, with polarisers, 46"), std::string::npos) << message;

  Bytes info(47, 0);
  info[1] = 1;
  info[46] = 0x3F;
  EXPECT_TRUE(hr::parse_info_payload(info, "dev").has_polarisers());
  info[46] = 0x40;
  EXPECT_EQ(kind_of([&] { hr::parse_info_payload(info, "dev"); }, &message), DeviceError::Kind::kProtocol);
  EXPECT_NE(message.find("byte 46"), std::string::npos) << message;
}

TEST(HidReports, ParsesAReply) {
  hr::Reply reply = hr::parse_reply(reply_report({0x02, 7, 0x04, 0x00, 2, 0xAB, 0xCD}), "dev");
  EXPECT_EQ(reply.sequence, 7);
  EXPECT_EQ(reply.command, 0x04);
  EXPECT_EQ(reply.status, 0);
  EXPECT_EQ(reply.payload, (Bytes{0xAB, 0xCD}));
}

TEST(HidReports, RejectsShortOversizedAndMalformedReports) {
  Bytes good = reply_report({0x02, 7, 0x04, 0x00, 2, 0xAB, 0xCD});
  Bytes short_report(good.begin(), good.begin() + 63);
  Bytes oversized = good;
  oversized.push_back(0);
  Bytes wrong_id = good;
  wrong_id[0] = 0x01;
  Bytes long_payload = good;
  long_payload[4] = 60;
  Bytes dirty_padding = good;
  dirty_padding[40] = 1;
  std::string message;
  for (const Bytes& bad : {short_report, oversized, wrong_id, long_payload, dirty_padding, Bytes{}})
    EXPECT_EQ(kind_of([&] { hr::parse_reply(bad, "dev"); }, &message), DeviceError::Kind::kProtocol) << message;
  kind_of([&] { hr::parse_reply(short_report, "dev"); }, &message);
  EXPECT_NE(message.find("short report: 63 bytes"), std::string::npos) << message;

  EXPECT_EQ(kind_of([] { hr::parse_info_payload(Bytes(45, 0), "dev"); }), DeviceError::Kind::kProtocol);
  EXPECT_EQ(kind_of([] { hr::parse_status_payload(Bytes(41, 0), "dev"); }), DeviceError::Kind::kProtocol);
  EXPECT_EQ(kind_of([] { hr::parse_status_payload(Bytes(40, 0), "dev"); }), DeviceError::Kind::kProtocol);  // before the pulse counter
  Bytes status(44, 0);
  status[40] = 0x02, status[41] = 0x01, status[43] = 0x80;  // trigger pulses, u32 little endian
  EXPECT_EQ(hr::parse_status_payload(status, "dev").trigger_pulses, 0x80000102u);
  EXPECT_EQ(hr::parse_fire_trigger_payload(Bytes{7, 0, 0, 0}, "dev"), 7u);
  EXPECT_EQ(kind_of([] { hr::parse_fire_trigger_payload(Bytes(3, 0), "dev"); }), DeviceError::Kind::kProtocol);
  Bytes bad_mode(46, 0);
  bad_mode[0] = 7;
  bad_mode[1] = 1;
  EXPECT_EQ(kind_of([&] { hr::parse_info_payload(bad_mode, "dev"); }), DeviceError::Kind::kProtocol);
}

TEST(HidLedController, BadRepliesOverTheSeamAreProtocolErrorsAndTheLinkRecovers) {
  simulators::LedControllerSimulator sim;
  auto transport = sim.make_hid_transport();
  simulators::HidLedDevice* device = transport.get();
  auto led = drivers::make_hid_led_controller(std::move(transport));
  using simulators::HidReplyCorruption;
  for (HidReplyCorruption corruption : {HidReplyCorruption::kShort, HidReplyCorruption::kOversized,
                                        HidReplyCorruption::kWrongSequence, HidReplyCorruption::kBadLength}) {
    device->corrupt_next_reply(corruption);
    std::string message;
    EXPECT_EQ(kind_of([&] { led->read_status(); }, &message), DeviceError::Kind::kProtocol) << message;
    EXPECT_NE(message.find("SIM-LED-0001"), std::string::npos) << message;
    EXPECT_NO_THROW(led->read_status());
  }
}

TEST(HidLedController, LateReplyToATimedOutCommandIsSkipped) {
  simulators::LedControllerSimulator sim;
  auto led = drivers::make_hid_led_controller(sim.make_hid_transport());
  sim.lab().set_unresponsive(true);
  EXPECT_EQ(kind_of([&] { led->read_status(); }), DeviceError::Kind::kTimeout);
  sim.lab().set_unresponsive(false);
  drivers::LedState state;
  state.drive[0] = 0.25;
  led->set_state(state);
  EXPECT_NEAR(led->read_status().applied.drive[0], 0.25, 1e-4);
}

TEST(HidLedController, NoSuchDeviceIsNotFound) {
  // Real hidapi enumeration: pid.codes' test VID/PID is not attached here.
  std::string message;
  EXPECT_EQ(kind_of([] { drivers::make_hid_led_controller(0x1209, 0x0001, "NO-SUCH-SERIAL"); }, &message),
            DeviceError::Kind::kNotFound)
      << message;
}

}  // namespace
}  // namespace chromo
