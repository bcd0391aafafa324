// The LED controller drivers against the LED simulator over each real
// protocol: Modbus TCP on 127.0.0.1, Modbus RTU over a pseudo-terminal pair,
// and HID reports over the HidTransport seam. Every scenario runs on all three.

#include <gtest/gtest.h>

#include <atomic>
#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led_controller_factory.hpp"
#include "chromo/simulators/leds/led_controller_simulator.hpp"

namespace chromo {
namespace {

using drivers::DeviceError;
using drivers::LedState;
using spectral::LedType;

LedState state_of(std::initializer_list<double> levels, double pwm_hz = 0) {
  LedState state;
  int i = 0;
  for (double level : levels) state.drive[i++] = level;
  state.pwm_frequency_hz = pwm_hz;
  return state;
}

enum class Link { kTcp, kRtu, kHid };

class LedControllerTest : public ::testing::TestWithParam<Link> {
 protected:
  LedControllerTest() : sim_(options()) {}
  static simulators::LedLabOptions options() {
    simulators::LedLabOptions o;
    o.zone_count = 2;
    o.sequence_capacity = 20;
    return o;
  }
  std::unique_ptr<drivers::LedController> connect(std::chrono::milliseconds timeout = std::chrono::milliseconds(300)) {
    if (GetParam() == Link::kHid) {
      drivers::HidLinkOptions hid;
      hid.reply_timeout = timeout;
      return drivers::make_hid_led_controller(sim_.make_hid_transport(), hid);
    }
    drivers::ModbusLinkOptions link;
    link.response_timeout = timeout;
    if (GetParam() == Link::kTcp) return drivers::make_modbus_tcp_led_controller("127.0.0.1", sim_.start_modbus_tcp(), link);
    return drivers::make_modbus_rtu_led_controller(sim_.start_modbus_rtu(), 115200, link);
  }
  simulators::LedControllerSimulator sim_;
};

TEST_P(LedControllerTest, ReadsTheDeviceInformation) {
  auto led = connect();
  drivers::LedControllerInfo info = led->info();
  EXPECT_EQ(info.model, "CHROMO-LED6-SIM");
  EXPECT_EQ(info.serial, "SIM-LED-0001");
  EXPECT_EQ(info.firmware_version, "1.0");
  EXPECT_EQ(info.drive_mode, drivers::DriveMode::kPwmDuty);
  EXPECT_EQ(info.zone_count, 2);
  EXPECT_EQ(info.sequence_capacity, 20);
  EXPECT_EQ(info.min_pwm_frequency_hz, 100);
  EXPECT_EQ(info.max_pwm_frequency_hz, 40000);
}

TEST_P(LedControllerTest, SetsAndReadsBackAState) {
  auto led = connect();
  led->set_output_enabled(true);
  LedState state = state_of({0.5, 0.25, 0, 0.125, 1.0, 0.75}, 2000);
  led->set_state(state);
  drivers::LedStatus status = led->read_status();
  EXPECT_TRUE(status.output_enabled);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(status.applied.drive[i], state.drive[i], 1.0 / 65535) << i;
  EXPECT_EQ(status.applied.pwm_frequency_hz, 2000);
  EXPECT_FALSE(status.applied.zone.has_value());
  EXPECT_EQ(status.sequence_position, -1);
  EXPECT_EQ(status.controller_faults, 0u);
  EXPECT_NEAR(status.temperature_C[0], 25.0, 1.0);  // cold start at ambient
  // The lab (truth) received the same state.
  drivers::LedStatus truth = sim_.lab().status();
  EXPECT_NEAR(truth.applied.drive[4], 1.0, 1e-9);
  EXPECT_TRUE(sim_.lab().output_enabled());
  EXPECT_GT(sim_.lab().irradiance_now().max(), 0.1);

  led->set_output_enabled(false);
  EXPECT_FALSE(led->read_status().output_enabled);
  EXPECT_EQ(sim_.lab().irradiance_now().max(), 0.0);
}

TEST_P(LedControllerTest, SetsOneZone) {
  auto led = connect();
  LedState state = state_of({0.2, 0, 0, 0, 0, 0});
  state.zone = 1;
  led->set_state(state);
  drivers::LedStatus status = led->read_status();
  ASSERT_TRUE(status.applied.zone.has_value());
  EXPECT_EQ(*status.applied.zone, 1);
}

TEST_P(LedControllerTest, RefusesOutOfLimitRequestsWithoutSendingThem) {
  auto led = connect();
  led->set_state(state_of({0.1, 0, 0, 0, 0, 0}));
  auto expect_invalid = [&](const LedState& state) {
    try {
      led->set_state(state);
      ADD_FAILURE() << "accepted";
    } catch (const DeviceError& e) {
      EXPECT_EQ(e.kind(), DeviceError::Kind::kInvalidRequest) << e.what();
    }
  };
  expect_invalid(state_of({1.5, 0, 0, 0, 0, 0}));
  expect_invalid(state_of({0, 0, 0, 0, 0, -0.1}));
  expect_invalid(state_of({0.5, 0, 0, 0, 0, 0}, 50));       // below the PWM limit
  LedState bad_zone = state_of({0.5, 0, 0, 0, 0, 0});
  bad_zone.zone = 2;
  expect_invalid(bad_zone);
  try {
    led->arm_sequence(std::vector<LedState>(21, state_of({0.5, 0, 0, 0, 0, 0})),
                      drivers::SequenceTrigger::kSoftware);  // capacity 20
    ADD_FAILURE() << "accepted";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kInvalidRequest) << e.what();
  }
  drivers::LedStatus status = led->read_status();
  EXPECT_NEAR(status.applied.drive[0], 0.1, 1e-4);  // nothing changed
  EXPECT_EQ(status.sequence_position, -1);
}

TEST_P(LedControllerTest, HardwareSequenceAdvancesOnTheTriggerInput) {
  auto led = connect();
  std::vector<LedState> states;
  for (int k = 0; k < 15; ++k) states.push_back(state_of({k / 20.0, 0, 0, 0, 0, 0}));  // spans two table writes
  led->arm_sequence(states, drivers::SequenceTrigger::kHardwareRisingEdge);
  EXPECT_EQ(led->read_status().sequence_position, 0);
  sim_.trigger();
  sim_.trigger();
  drivers::LedStatus status = led->read_status();
  EXPECT_EQ(status.sequence_position, 2);
  EXPECT_NEAR(status.applied.drive[0], 2 / 20.0, 1e-4);
  for (int k = 0; k < 20; ++k) sim_.trigger();  // past the end: stays on the last state
  EXPECT_EQ(led->read_status().sequence_position, 14);
  EXPECT_THROW(led->advance_sequence(), DeviceError);  // not a software sequence: refused
  led->disarm_sequence();
  EXPECT_EQ(led->read_status().sequence_position, -1);
}

TEST_P(LedControllerTest, FiresNumberedTriggerPulsesAndRefusesBadWidthsUnsent) {
  auto led = connect();
  std::atomic<int> edges{0};  // the wired input (a camera's Line0)
  sim_.lab().connect_trigger_output([&] { ++edges; });
  EXPECT_EQ(led->read_status().trigger_pulses, 0u);
  EXPECT_EQ(led->fire_trigger(100), 1u);
  EXPECT_EQ(led->fire_trigger(drivers::kMinTriggerPulseWidthUs), 2u);
  EXPECT_EQ(led->fire_trigger(drivers::kMaxTriggerPulseWidthUs), 3u);
  EXPECT_EQ(edges.load(), 3);
  EXPECT_EQ(led->read_status().trigger_pulses, 3u);
  for (std::uint32_t width : {0u, drivers::kMaxTriggerPulseWidthUs + 1}) {
    try {
      led->fire_trigger(width);
      ADD_FAILURE() << "a " << width << " us pulse was accepted";
    } catch (const DeviceError& error) {
      EXPECT_EQ(error.kind(), DeviceError::Kind::kInvalidRequest);
      EXPECT_NE(std::string(error.what()).find("pulse width"), std::string::npos) << error.what();
    }
  }
  EXPECT_EQ(sim_.lab().trigger_pulses(), 3u);  // nothing was sent
  EXPECT_EQ(edges.load(), 3);
}

TEST_P(LedControllerTest, TriggerOutputSequenceShowsTheNextStateBeforeThePulseLeaves) {
  auto led = connect();
  std::vector<LedState> states;
  for (int k = 0; k < 5; ++k) states.push_back(state_of({k / 10.0, 0, 0, 0, 0, 0}));
  led->arm_sequence(states, drivers::SequenceTrigger::kTriggerOutput);
  std::vector<double> at_edge;  // W57 as the lab emits it when the pulse reaches the input
  sim_.lab().connect_trigger_output([&] { at_edge.push_back(sim_.lab().status().applied.drive[0]); });
  sim_.trigger();  // an edge on the trigger *input* does not move an output-triggered sequence
  EXPECT_EQ(led->read_status().sequence_position, 0);
  for (int k = 1; k <= 3; ++k) EXPECT_EQ(led->fire_trigger(100), static_cast<std::uint32_t>(k));
  ASSERT_EQ(at_edge.size(), 3u);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(at_edge[k], (k + 1) / 10.0, 1e-4) << k;
  EXPECT_EQ(led->read_status().sequence_position, 3);
  EXPECT_THROW(led->advance_sequence(), DeviceError);  // not a software sequence: refused
}

TEST_P(LedControllerTest, SoftwareSequenceAdvancesOnCommand) {
  auto led = connect();
  std::vector<LedState> states{state_of({0, 0, 0, 0.1, 0, 0}), state_of({0, 0, 0, 0.2, 0, 0})};
  led->arm_sequence(states, drivers::SequenceTrigger::kSoftware);
  sim_.trigger();  // hardware edges do not move a software sequence
  EXPECT_EQ(led->read_status().sequence_position, 0);
  led->advance_sequence();
  drivers::LedStatus status = led->read_status();
  EXPECT_EQ(status.sequence_position, 1);
  EXPECT_NEAR(status.applied.drive[3], 0.2, 1e-4);
}

TEST_P(LedControllerTest, ControllerThatStopsAnsweringTimesOut) {
  auto led = connect(std::chrono::milliseconds(100));
  led->set_state(state_of({0.3, 0, 0, 0, 0, 0}));
  sim_.lab().set_unresponsive(true);
  try {
    led->set_state(state_of({0.4, 0, 0, 0, 0, 0}));
    FAIL() << "no timeout";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kTimeout) << e.what();
    EXPECT_NE(std::string(e.what()).find("set state"), std::string::npos) << e.what();
  }
  EXPECT_THROW(led->read_status(), DeviceError);
  sim_.lab().set_unresponsive(false);  // it comes back: the same link works again
  EXPECT_NEAR(led->read_status().applied.drive[0], 0.3, 1e-4);
  led->set_state(state_of({0.4, 0, 0, 0, 0, 0}));
  EXPECT_NEAR(led->read_status().applied.drive[0], 0.4, 1e-4);
}

TEST_P(LedControllerTest, OverTemperatureIsReportedAndRefused) {
  auto led = connect();
  sim_.lab().set_over_temperature(LedType::kRed, true);
  drivers::LedStatus status = led->read_status();
  EXPECT_EQ(status.channel_faults[3], drivers::kLedFaultOverTemperature);
  EXPECT_EQ(status.controller_faults, drivers::kLedFaultOverTemperature);
  EXPECT_GT(status.temperature_C[3], 85.0);
  try {
    led->set_state(state_of({0.5, 0, 0, 0, 0, 0}));
    FAIL() << "accepted";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kFault) << e.what();
    EXPECT_NE(std::string(e.what()).find("over-temperature"), std::string::npos) << e.what();
  }
  EXPECT_EQ(led->read_status().applied.drive[0], 0.0);  // refused: nothing changed
}

TEST_P(LedControllerTest, DeadChannelIsAnOpenCircuitFault) {
  auto led = connect();
  led->set_output_enabled(true);
  sim_.lab().set_dead_channel(LedType::kGreen, true);
  led->set_state(state_of({0.5, 0, 0, 0, 0, 0}));  // green not driven: fine
  try {
    led->set_state(state_of({0.5, 0, 0, 0, 0.5, 0}));
    FAIL() << "no fault";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kFault) << e.what();
    EXPECT_NE(std::string(e.what()).find("G: open circuit"), std::string::npos) << e.what();
  }
  EXPECT_EQ(led->read_status().channel_faults[4], drivers::kLedFaultOpenCircuit);
}

INSTANTIATE_TEST_SUITE_P(Links, LedControllerTest, ::testing::Values(Link::kTcp, Link::kRtu, Link::kHid),
                         [](const auto& info) {
                           return info.param == Link::kTcp ? "ModbusTcp" : info.param == Link::kRtu ? "ModbusRtu" : "Hid";
                         });

TEST(ModbusLedConnect, NothingListeningIsNotFound) {
  try {
    drivers::make_modbus_tcp_led_controller("127.0.0.1", 1);
    FAIL() << "connected";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kNotFound) << e.what();
  }
}

}  // namespace
}  // namespace chromo
