// The Modbus input registers as the device answers them, decoded without a
// device (drivers/led/modbus_registers.hpp); the same functions are fuzzed.
#include <gtest/gtest.h>

#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led/led_modbus_map.hpp"
#include "chromo/drivers/led/modbus_registers.hpp"

namespace chromo::drivers::led_modbus {
namespace {

std::vector<std::uint16_t> good_info() {
  std::vector<std::uint16_t> r(kInInfoCount, 0);
  r[kInProtocolVersion] = kProtocolVersion;
  r[kInDriveMode] = 1;
  r[kInZoneCount] = 4;
  r[kInSequenceCapacity] = 60000;  // more than the map allows: clamped
  r[kInMinPwmHzHigh] = 0, r[kInMinPwmHzHigh + 1] = 1000;
  r[kInMaxPwmHzHigh] = 1, r[kInMaxPwmHzHigh + 1] = 0x86A0;  // 100000
  r[kInFirmwareVersion] = 0x0203;
  r[kInSerial] = ('S' << 8) | 'N', r[kInSerial + 1] = ('1' << 8);
  return r;
}

TEST(ModbusRegisters, DecodesTheInfoBlock) {
  const LedControllerInfo info = decode_info_registers(good_info(), "dev");
  EXPECT_EQ(info.drive_mode, DriveMode::kConstantCurrent);
  EXPECT_EQ(info.zone_count, 4);
  EXPECT_EQ(info.sequence_capacity, kMaxSequenceStates);
  EXPECT_EQ(info.min_pwm_frequency_hz, 1000u);
  EXPECT_EQ(info.max_pwm_frequency_hz, 100000u);
  EXPECT_EQ(info.firmware_version, "2.3");
  EXPECT_EQ(info.serial, "SN1");
}

TEST(ModbusRegisters, RefusesMalformedAnswersNamingTheDevice) {
  auto refused = [](std::vector<std::uint16_t> r, const std::string& detail) {
    try {
      decode_info_registers(r, "dev");
      ADD_FAILURE() << detail;
    } catch (const DeviceError& e) {
      EXPECT_EQ(e.kind(), DeviceError::Kind::kProtocol);
      EXPECT_NE(std::string(e.what()).find(detail), std::string::npos) << e.what();
    }
  };
  auto r = good_info();
  r[kInProtocolVersion] = 9;
  refused(r, "protocol version 9");
  r = good_info(), r[kInDriveMode] = 2;
  refused(r, "unknown drive mode 2");
  r = good_info(), r[kInZoneCount] = 0;
  refused(r, "zone count 0");
  r = good_info(), r.pop_back();
  refused(r, "31 registers, expected 32");
  EXPECT_THROW(decode_status_registers(std::vector<std::uint16_t>(3), "dev"), DeviceError);
}

TEST(ModbusRegisters, DecodesTheStatusBlock) {
  std::vector<std::uint16_t> r(kInStatusCount, 0);
  auto at = [&](int address) -> std::uint16_t& { return r[address - kInStatusFirst]; };
  at(kInAppliedDrive0) = kDriveFullScale;
  at(kInTemperature0 + 1) = static_cast<std::uint16_t>(-250);  // −2.5 °C, signed hundredths
  at(kInAppliedZone) = kAllZones;
  at(kInSequencePosition) = 0xFFFF;
  at(kInAckSequence) = 77;
  at(kInCommandResult) = 3;
  at(kInTriggerPulsesHigh) = 0x0001, at(kInTriggerPulsesHigh + 1) = 0x0002;  // high word first
  const StatusRegisters s = decode_status_registers(r, "dev");
  EXPECT_EQ(s.status.trigger_pulses, 65538u);
  EXPECT_DOUBLE_EQ(s.status.applied.drive[0], 1.0);
  EXPECT_DOUBLE_EQ(s.status.temperature_C[1], -2.5);
  EXPECT_FALSE(s.status.applied.zone.has_value());
  EXPECT_EQ(s.status.sequence_position, -1);
  EXPECT_EQ(s.ack_sequence, 77);
  EXPECT_EQ(s.command_result, 3);
}

}  // namespace
TEST(ModbusRegisters, DecodesThePolarisationRegistersAndRefusesBadOnes) {
  auto info_registers = good_info();
  EXPECT_FALSE(decode_info_registers(info_registers, "dev").has_polarisers());  // 0: no polarisers
  info_registers[kInPolariserBanks] = 0x21;  // W57 and B
  const LedControllerInfo info = decode_info_registers(info_registers, "dev");
  EXPECT_EQ(info.polariser_banks, (std::array<bool, kLedTypeCount>{true, false, false, false, false, true}));
  info_registers[kInPolariserBanks] = 0x40;
  try {
    decode_info_registers(info_registers, "dev");
    ADD_FAILURE() << "bank bit 6 accepted";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kProtocol);
    EXPECT_NE(std::string(e.what()).find("input register 0x0009"), std::string::npos) << e.what();
  }
  std::vector<std::uint16_t> r(kInStatusCount, 0);
  r[kInAppliedPolarisation - kInStatusFirst] = 0x0809;  // W57 cross, W40 parallel, B parallel
  const PolarisationPerType applied = decode_status_registers(r, "dev").status.applied.polarisation;
  EXPECT_EQ(applied, (PolarisationPerType{Polarisation::kCross, Polarisation::kParallel, Polarisation::kUnpolarised,
                                          Polarisation::kUnpolarised, Polarisation::kUnpolarised,
                                          Polarisation::kParallel}));
  for (std::uint16_t bad : {std::uint16_t{0x0003}, std::uint16_t{0x0C00}, std::uint16_t{0x1000}}) {
    r[kInAppliedPolarisation - kInStatusFirst] = bad;
    try {
      decode_status_registers(r, "dev");
      ADD_FAILURE() << bad;
    } catch (const DeviceError& e) {
      EXPECT_EQ(e.kind(), DeviceError::Kind::kProtocol);
      EXPECT_NE(std::string(e.what()).find("input register 0x003E"), std::string::npos) << e.what();
    }
  }
}

}  // namespace chromo::drivers::led_modbus
