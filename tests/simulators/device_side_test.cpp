// The simulators' own protocol parsers: what the device side does with bad
// command bytes (the driver side never sends them, so they are tested here
// with hand-made bytes).

#include <gtest/gtest.h>

#include <modbus/modbus.h>

#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/simulators/leds/led_controller_simulator.hpp"
#include "chromo/simulators/spectrometer/usb_spectrometer_device.hpp"

namespace chromo::simulators {
namespace {

using Bytes = std::vector<std::uint8_t>;

// Sends a command report, returns the status byte of the reply.
int hid_status(HidLedDevice& device, const Bytes& report) {
  device.write_report(report);
  Bytes reply(128);
  std::size_t n = device.read_report(reply, 10);
  EXPECT_EQ(n, 64u);
  EXPECT_EQ(reply[0], 0x02);
  return reply[3];
}

Bytes command(std::uint8_t code, Bytes payload) {
  Bytes report(64, 0);
  report[0] = 0x01;
  report[1] = 9;
  report[2] = code;
  report[3] = static_cast<std::uint8_t>(payload.size());
  std::copy(payload.begin(), payload.end(), report.begin() + 4);
  return report;
}

TEST(HidLedDevice, AnswersBadCommandsWithTheDocumentedStatus) {
  LedControllerSimulator sim;
  auto device = sim.make_hid_transport();
  EXPECT_EQ(hid_status(*device, command(0x03, {})), 0x00);          // get status: ok
  EXPECT_EQ(hid_status(*device, command(0x7F, {})), 0x01);          // unknown command
  EXPECT_EQ(hid_status(*device, command(0x04, {1, 0})), 0x02);      // set output: 2 bytes instead of 1
  EXPECT_EQ(hid_status(*device, command(0x04, {2})), 0x03);         // set output: 2 is out of range
  EXPECT_EQ(hid_status(*device, command(0x07, {})), 0x04);          // arm before a sequence was loaded
  Bytes short_report = command(0x03, {});
  short_report.resize(20);
  EXPECT_EQ(hid_status(*device, short_report), 0x06);               // malformed: short
  Bytes dirty = command(0x03, {});
  dirty[50] = 0xAA;
  EXPECT_EQ(hid_status(*device, dirty), 0x06);                      // malformed: padding
  Bytes wrong_id = command(0x03, {});
  wrong_id[0] = 0x02;
  EXPECT_EQ(hid_status(*device, wrong_id), 0x06);
  EXPECT_FALSE(sim.lab().output_enabled());                         // nothing acted on
}

TEST(HidLedDevice, FireTriggerRefusesBadWidthsAndNumbersGoodPulses) {
  LedControllerSimulator sim;
  auto device = sim.make_hid_transport();
  EXPECT_EQ(hid_status(*device, command(0x0A, {0x00, 0x00})), 0x03);  // 0 us: out of range
  EXPECT_EQ(hid_status(*device, command(0x0A, {0x11, 0x27})), 0x03);  // 10001 us: out of range
  EXPECT_EQ(hid_status(*device, command(0x0A, {100})), 0x02);         // one byte: bad length
  EXPECT_EQ(hid_status(*device, command(0x05, {1, 0, 3})), 0x03);     // sequence trigger 3: unknown
  EXPECT_EQ(sim.lab().trigger_pulses(), 0u);                          // nothing fired
  device->write_report(command(0x0A, {0x10, 0x27}));                  // 10000 us
  Bytes reply(128);
  ASSERT_EQ(device->read_report(reply, 10), 64u);
  EXPECT_EQ(reply[3], 0x00);
  ASSERT_EQ(reply[4], 4);  // the pulse's number, u32 little endian
  EXPECT_EQ(reply[5] | reply[6] << 8 | reply[7] << 16 | reply[8] << 24, 1);
  EXPECT_EQ(sim.lab().trigger_pulses(), 1u);
}

// Writes the command block at 0x0009 (code, sequence, length, trigger, pulse
// width) in one FC 16 and returns the result code (input register 0x002C)
// after checking the acknowledged sequence (0x0029).
int modbus_result(modbus_t* ctx, std::vector<std::uint16_t> block) {
  EXPECT_EQ(modbus_write_registers(ctx, 0x0009, static_cast<int>(block.size()), block.data()),
            static_cast<int>(block.size()));
  std::uint16_t status[4] = {};
  EXPECT_EQ(modbus_read_input_registers(ctx, 0x0029, 4, status), 4);
  EXPECT_EQ(status[0], block[1]);
  return status[3];
}

std::uint32_t modbus_pulses(modbus_t* ctx) {
  std::uint16_t pulses[2] = {};
  EXPECT_EQ(modbus_read_input_registers(ctx, 0x002D, 2, pulses), 2);
  return std::uint32_t(pulses[0]) << 16 | pulses[1];
}

TEST(ModbusLedServer, FireTriggerRefusesBadWidthsAndCountsGoodPulses) {
  LedControllerSimulator sim;
  const int port = sim.start_modbus_tcp();
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  EXPECT_EQ(modbus_result(ctx, {5, 1, 0, 0, 0}), 2);      // FIRE_TRIGGER 0 us: out of range
  EXPECT_EQ(modbus_result(ctx, {5, 2, 0, 0, 10001}), 2);  // 10001 us: out of range
  EXPECT_EQ(modbus_pulses(ctx), 0u);
  EXPECT_EQ(modbus_result(ctx, {5, 3, 0, 0, 100}), 0);
  EXPECT_EQ(modbus_result(ctx, {5, 4, 0, 0, 1}), 0);
  EXPECT_EQ(modbus_pulses(ctx), 2u);
  EXPECT_EQ(sim.lab().trigger_pulses(), 2u);
  EXPECT_EQ(modbus_result(ctx, {2, 5, 1, 3, 0}), 2);      // ARM_SEQUENCE with trigger 3: out of range
  EXPECT_EQ(sim.lab().status().sequence_position, -1);
  modbus_close(ctx);
  modbus_free(ctx);
}

TEST(UsbSpectrometerDevice, IgnoresMalformedCommandsLikeTheDevice) {
  LedLab lab;
  UsbSpectrometerDevice device(lab);
  device.bulk_write(0x01, Bytes{0x02, 0x10, 0x27}, 100);        // integration time cut short
  device.bulk_write(0x01, Bytes{0x02, 0x10, 0x00, 0x00, 0x00}, 100);  // 16 µs: below the minimum
  device.bulk_write(0x01, Bytes{0x42}, 100);                     // unknown
  device.bulk_write(0x01, Bytes{}, 100);
  EXPECT_EQ(device.ignored_commands(), 4);
  EXPECT_EQ(device.integration_time_us(), 100000u);
  Bytes buffer(512);
  EXPECT_THROW(device.bulk_read(0x81, buffer, 10), drivers::DeviceError);  // nothing to answer: timeout
  EXPECT_THROW(device.bulk_write(0x02, Bytes{0x01}, 100), drivers::DeviceError);  // no such endpoint
}

TEST(DetectorModel, ResponseIsNotFlatAndADarkSpectrumIsTheDarkLevelInNinePackets) {
  DetectorModel model;
  EXPECT_NEAR(model.response_at_nm(600), 1.0, 1e-12);
  EXPECT_LT(model.response_at_nm(400), 0.6);
  EXPECT_LT(model.response_at_nm(780), 0.7);
  EXPECT_NEAR(model.wavelength_nm(0), 339.5, 1e-12);
  EXPECT_GT(model.wavelength_nm(2047), 1000.0);
  // LEDs off: every pixel at the dark level plus 0.1 s of dark current, sent as
  // 8 × 512 bytes and the 1-byte sync packet.
  LedLab lab;
  UsbSpectrometerDevice device(lab, model);
  device.bulk_write(0x01, Bytes{0x09}, 100);
  Bytes packet(512);
  std::size_t total = 0, n = 0;
  double sum = 0;
  while ((n = device.bulk_read(0x82, packet, 100)) == 512) {
    for (std::size_t i = 0; i < n; i += 2) sum += packet[i] | packet[i + 1] << 8;
    total += n;
  }
  EXPECT_EQ(total, 4096u);
  EXPECT_EQ(n, 1u);
  EXPECT_EQ(packet[0], 0x69);
  EXPECT_NEAR(sum / 2048, 1500 + 200 * 0.1, 1.0);
}

}  // namespace
}  // namespace chromo::simulators
