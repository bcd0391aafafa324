// Polarisation states through the LED controller drivers and the simulator
// over each real protocol (Modbus TCP, Modbus RTU, HID reports):
// docs/polarisation.md, docs/protocols/led-modbus.md, led-hid.md.

#include <gtest/gtest.h>

#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led_controller_factory.hpp"
#include "chromo/simulators/leds/led_controller_simulator.hpp"

namespace chromo {
namespace {

using drivers::DeviceError;
using drivers::LedState;
using drivers::Polarisation;
using spectral::LedType;

enum class PolarisedLink { kTcp, kRtu, kHid };

// A sphere with cross and parallel banks for every type but red (a retrofit
// that left the red LEDs unpolarised), or a sphere without polarisers.
simulators::LedLabOptions sphere_options(bool with_polarisers) {
  simulators::LedLabOptions options;
  options.zone_count = 2;
  options.sequence_capacity = 8;
  if (with_polarisers) {
    options.polariser_banks.fill(true);
    options.polariser_banks[led_type_index(LedType::kRed)] = false;
  }
  return options;
}

LedState w57_and_blue(Polarisation w57, Polarisation blue) {
  LedState state;
  state.drive[led_type_index(LedType::kW57)] = 0.5;
  state.drive[led_type_index(LedType::kBlue)] = 0.25;
  state.polarisation[led_type_index(LedType::kW57)] = w57;
  state.polarisation[led_type_index(LedType::kBlue)] = blue;
  return state;
}

class LedPolarisationTest : public ::testing::TestWithParam<PolarisedLink> {
 protected:
  std::unique_ptr<drivers::LedController> connect(simulators::LedControllerSimulator& sim) {
    if (GetParam() == PolarisedLink::kHid) return drivers::make_hid_led_controller(sim.make_hid_transport());
    if (GetParam() == PolarisedLink::kTcp)
      return drivers::make_modbus_tcp_led_controller("127.0.0.1", sim.start_modbus_tcp());
    return drivers::make_modbus_rtu_led_controller(sim.start_modbus_rtu(), 115200);
  }
};

TEST_P(LedPolarisationTest, ReadsWhichLedTypesHavePolariserBanks) {
  simulators::LedControllerSimulator polarised(sphere_options(true)), plain(sphere_options(false));
  const drivers::LedControllerInfo info = connect(polarised)->info();
  EXPECT_TRUE(info.has_polarisers());
  for (LedType type : spectral::kAllLedTypes)
    EXPECT_EQ(info.polariser_banks[led_type_index(type)], type != LedType::kRed) << led_type_name(type);
  EXPECT_FALSE(connect(plain)->info().has_polarisers());
}

TEST_P(LedPolarisationTest, AppliesCrossAndParallelAndReadsThemBack) {
  simulators::LedControllerSimulator sim(sphere_options(true));
  auto led = connect(sim);
  const LedState state = w57_and_blue(Polarisation::kCross, Polarisation::kParallel);
  led->set_state(state);
  EXPECT_EQ(led->read_status().applied.polarisation, state.polarisation);
  EXPECT_EQ(sim.lab().polarisation_in_zone(0), state.polarisation);  // the truth got it
  EXPECT_EQ(sim.lab().polarisation_in_zone(1), state.polarisation);

  LedState zone_one = w57_and_blue(Polarisation::kParallel, Polarisation::kUnpolarised);
  zone_one.zone = 1;
  led->set_state(zone_one);
  EXPECT_EQ(sim.lab().polarisation_in_zone(0), state.polarisation);
  EXPECT_EQ(sim.lab().polarisation_in_zone(1), zone_one.polarisation);
  EXPECT_EQ(led->read_status().applied.polarisation, zone_one.polarisation);
}

TEST_P(LedPolarisationTest, RefusesPolarisationWithoutABankUnsentNamingTheLedType) {
  simulators::LedControllerSimulator polarised(sphere_options(true)), plain(sphere_options(false));
  for (auto* sim : {&polarised, &plain}) {
    auto led = connect(*sim);
    const LedState before = w57_and_blue(Polarisation::kUnpolarised, Polarisation::kUnpolarised);
    led->set_state(before);
    LedState bad = before;
    const LedType refused = sim == &polarised ? LedType::kRed : LedType::kW57;
    bad.drive[led_type_index(refused)] = 1.0;
    bad.polarisation[led_type_index(refused)] = Polarisation::kCross;
    try {
      led->set_state(bad);
      ADD_FAILURE() << "accepted";
    } catch (const DeviceError& e) {
      EXPECT_EQ(e.kind(), DeviceError::Kind::kInvalidRequest);
      EXPECT_NE(std::string(e.what()).find("no polariser bank for " + std::string(led_type_name(refused))),
                std::string::npos)
          << e.what();
    }
    LedState unknown_code = before;
    unknown_code.polarisation[0] = static_cast<Polarisation>(3);
    EXPECT_THROW(led->set_state(unknown_code), DeviceError);
    EXPECT_THROW(led->arm_sequence(std::vector<LedState>{before, bad}, drivers::SequenceTrigger::kSoftware),
                 DeviceError);
    const drivers::LedStatus status = led->read_status();  // nothing changed
    EXPECT_NEAR(status.applied.drive[led_type_index(refused)], before.drive[led_type_index(refused)], 1.0 / 65535);
    EXPECT_EQ(status.applied.polarisation, before.polarisation);
    EXPECT_EQ(status.sequence_position, -1);
  }
}

TEST_P(LedPolarisationTest, SequenceSwitchesBetweenCrossAndParallelBanks) {
  simulators::LedControllerSimulator sim(sphere_options(true));
  auto led = connect(sim);
  const std::vector<LedState> states{w57_and_blue(Polarisation::kCross, Polarisation::kCross),
                                     w57_and_blue(Polarisation::kParallel, Polarisation::kParallel),
                                     w57_and_blue(Polarisation::kUnpolarised, Polarisation::kCross)};
  led->arm_sequence(states, drivers::SequenceTrigger::kSoftware);
  for (std::size_t k = 0; k < states.size(); ++k) {
    if (k > 0) led->advance_sequence();
    EXPECT_EQ(sim.lab().polarisation_in_zone(0), states[k].polarisation) << k;
    EXPECT_EQ(led->read_status().applied.polarisation, states[k].polarisation) << k;
  }
}

TEST_P(LedPolarisationTest, SphereWithoutPolarisersWorksAsBefore) {
  simulators::LedControllerSimulator sim(sphere_options(false));
  auto led = connect(sim);
  LedState state = w57_and_blue(Polarisation::kUnpolarised, Polarisation::kUnpolarised);
  state.pwm_frequency_hz = 2000;
  led->set_state(state);
  const drivers::LedStatus status = led->read_status();
  for (int i = 0; i < spectral::kLedTypeCount; ++i) EXPECT_NEAR(status.applied.drive[i], state.drive[i], 1.0 / 65535);
  EXPECT_EQ(status.applied.pwm_frequency_hz, 2000);
  EXPECT_EQ(status.applied.polarisation, drivers::PolarisationPerType{});
  led->arm_sequence(std::vector<LedState>{state, state}, drivers::SequenceTrigger::kSoftware);
  led->advance_sequence();
  EXPECT_EQ(led->read_status().sequence_position, 1);
}

INSTANTIATE_TEST_SUITE_P(Links, LedPolarisationTest,
                         ::testing::Values(PolarisedLink::kTcp, PolarisedLink::kRtu, PolarisedLink::kHid),
                         [](const ::testing::TestParamInfo<PolarisedLink>& info) {
                           return info.param == PolarisedLink::kTcp   ? std::string("ModbusTcp")
                                  : info.param == PolarisedLink::kRtu ? std::string("ModbusRtu")
                                                                      : std::string("Hid");
                         });

}  // namespace
}  // namespace chromo
