// The simulators' own protocol parsers: what the device side does with bad
// command bytes (the driver side never sends them, so they are tested here
// with hand-made bytes).

#include <gtest/gtest.h>

#include <modbus/modbus.h>

#include <optional>
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

// ---- Polarisation (docs/polarisation.md): the device's own reading of the fields ----

LedLabOptions polarised_sphere() {  // banks for every LED type but red (index 3)
  LedLabOptions options;
  options.polariser_banks.fill(true);
  options.polariser_banks[3] = false;
  return options;
}

// Writes the staging block 0x0000-0x000E (W57 at `w57_level`, all zones,
// PWM 0, APPLY_STATE, `sequence`, polarisation word) and returns the result code.
int modbus_apply(modbus_t* ctx, std::uint16_t w57_level, std::uint16_t sequence, std::uint16_t polarisation_word) {
  std::vector<std::uint16_t> block(15, 0);
  block[0] = w57_level;
  block[6] = 0xFFFF;
  block[9] = 1;
  block[10] = sequence;
  block[14] = polarisation_word;
  EXPECT_EQ(modbus_write_registers(ctx, 0, 15, block.data()), 15);
  std::uint16_t status[4] = {};
  EXPECT_EQ(modbus_read_input_registers(ctx, 0x0029, 4, status), 4);
  EXPECT_EQ(status[0], sequence);
  return status[3];
}

TEST(ModbusLedServer, RefusesBadPolarisationWordsWithResultFiveAndChangesNothing) {
  LedControllerSimulator sim(polarised_sphere());
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", sim.start_modbus_tcp());
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  std::uint16_t banks = 0;
  ASSERT_EQ(modbus_read_input_registers(ctx, 0x0009, 1, &banks), 1);
  EXPECT_EQ(banks, 0x37);  // W57, W40, W27, G, B
  EXPECT_EQ(modbus_apply(ctx, 1000, 1, 0x0001 | 0x0800), 0);  // W57 cross, B parallel
  const drivers::PolarisationPerType applied = sim.lab().polarisation_in_zone(0);
  EXPECT_EQ(applied[0], drivers::Polarisation::kCross);
  EXPECT_EQ(applied[5], drivers::Polarisation::kParallel);
  std::uint16_t word = 0;
  ASSERT_EQ(modbus_read_input_registers(ctx, 0x003E, 1, &word), 1);
  EXPECT_EQ(word, 0x0801);
  EXPECT_EQ(modbus_apply(ctx, 2000, 2, 0x0003), 5);  // code 3 for W57
  EXPECT_EQ(modbus_apply(ctx, 2000, 3, 0x1000), 5);  // bit 12
  EXPECT_EQ(modbus_apply(ctx, 2000, 4, 0x0040), 5);  // red cross: red has no bank
  EXPECT_NEAR(sim.lab().status().applied.drive[0], 1000 / 65535.0, 1e-12);  // nothing changed
  EXPECT_EQ(sim.lab().polarisation_in_zone(0), applied);
  // A sequence table entry's tenth register is its polarisation word.
  std::vector<std::uint16_t> entry{1000, 0, 0, 0, 0, 0, 0xFFFF, 0, 0, 0x0003};
  ASSERT_EQ(modbus_write_registers(ctx, 0x0100, 10, entry.data()), 10);
  EXPECT_EQ(modbus_result(ctx, {2, 5, 1, 1, 0}), 5);
  EXPECT_EQ(sim.lab().status().sequence_position, -1);
  modbus_close(ctx);
  modbus_free(ctx);
}

TEST(ModbusLedServer, VersionOneClientGetsUnpolarisedLight) {
  for (bool polarised : {false, true}) {
    LedControllerSimulator sim(polarised ? polarised_sphere() : LedLabOptions{});
    modbus_t* ctx = modbus_new_tcp("127.0.0.1", sim.start_modbus_tcp());
    ASSERT_NE(ctx, nullptr);
    ASSERT_EQ(modbus_connect(ctx), 0);
    std::uint16_t banks = 0xAAAA;
    ASSERT_EQ(modbus_read_input_registers(ctx, 0x0009, 1, &banks), 1);
    EXPECT_EQ(banks, polarised ? 0x37 : 0);
    // The version-1 write: 0x0000-0x000A only.
    std::vector<std::uint16_t> block{30000, 0, 0, 0, 0, 0, 0xFFFF, 0, 0, 1, 7};
    ASSERT_EQ(modbus_write_registers(ctx, 0, 11, block.data()), 11);
    std::uint16_t status[31] = {};
    ASSERT_EQ(modbus_read_input_registers(ctx, 0x0020, 31, status), 31);
    EXPECT_EQ(status[0x29 - 0x20], 7);  // acknowledged
    EXPECT_EQ(status[0x2C - 0x20], 0);  // OK
    EXPECT_EQ(status[0], 30000);
    EXPECT_EQ(status[0x3E - 0x20], 0);  // unpolarised
    EXPECT_EQ(sim.lab().polarisation_in_zone(0), drivers::PolarisationPerType{});
    if (!polarised) EXPECT_EQ(modbus_apply(ctx, 1000, 8, 0x0001), 5);  // cross without polarisers
    modbus_close(ctx);
    modbus_free(ctx);
  }
}

// Sends a command report and returns the whole reply.
Bytes hid_reply(HidLedDevice& device, const Bytes& report) {
  device.write_report(report);
  Bytes reply(128);
  EXPECT_EQ(device.read_report(reply, 10), 64u);
  reply.resize(64);
  return reply;
}

Bytes hid_state(std::uint16_t w57_level, std::optional<std::uint16_t> polarisation_word) {
  Bytes payload{0xFF, 0, 0, 0, 0, static_cast<std::uint8_t>(w57_level & 0xFF), static_cast<std::uint8_t>(w57_level >> 8)};
  payload.resize(17, 0);
  if (polarisation_word) {
    payload.push_back(static_cast<std::uint8_t>(*polarisation_word & 0xFF));
    payload.push_back(static_cast<std::uint8_t>(*polarisation_word >> 8));
  }
  return payload;
}

TEST(HidLedDevice, SphereWithoutPolarisersAnswersTheVersionOneLayout) {
  LedControllerSimulator sim;
  auto device = sim.make_hid_transport();
  EXPECT_EQ(hid_reply(*device, command(0x01, {}))[4], 46);  // info: no polariser bank byte
  EXPECT_EQ(hid_reply(*device, command(0x03, {}))[4], 44);  // status: no polarisation word
  EXPECT_EQ(hid_status(*device, command(0x02, hid_state(1000, 0))), 0x02);  // 19 bytes: bad length, as before
  EXPECT_EQ(hid_status(*device, command(0x02, hid_state(1000, std::nullopt))), 0x00);
  EXPECT_NEAR(sim.lab().status().applied.drive[0], 1000 / 65535.0, 1e-12);
}

TEST(HidLedDevice, PolarisedSphereTakesTheWordAndRefusesBadOnesWithStatusSeven) {
  LedControllerSimulator sim(polarised_sphere());
  auto device = sim.make_hid_transport();
  Bytes info = hid_reply(*device, command(0x01, {}));
  ASSERT_EQ(info[4], 47);
  EXPECT_EQ(info[5 + 46], 0x37);
  EXPECT_EQ(hid_status(*device, command(0x02, hid_state(1000, 0x0802))), 0x00);  // W57 parallel, B parallel
  EXPECT_EQ(sim.lab().polarisation_in_zone(0)[0], drivers::Polarisation::kParallel);
  Bytes status = hid_reply(*device, command(0x03, {}));
  ASSERT_EQ(status[4], 46);
  EXPECT_EQ(status[5 + 44] | status[5 + 45] << 8, 0x0802);
  EXPECT_EQ(hid_status(*device, command(0x02, hid_state(2000, 0x0003))), 0x07);  // code 3
  EXPECT_EQ(hid_status(*device, command(0x02, hid_state(2000, 0x8000))), 0x07);  // bit 15
  EXPECT_EQ(hid_status(*device, command(0x02, hid_state(2000, 0x0080))), 0x07);  // red parallel: no bank
  Bytes sequence_state{0, 0};
  Bytes bad = hid_state(2000, 0x0003);
  sequence_state.insert(sequence_state.end(), bad.begin(), bad.end());
  EXPECT_EQ(hid_status(*device, command(0x05, {1, 0, 1})), 0x00);
  EXPECT_EQ(hid_status(*device, command(0x06, sequence_state)), 0x07);
  EXPECT_EQ(hid_status(*device, command(0x07, {})), 0x04);  // the bad state was not loaded
  EXPECT_NEAR(sim.lab().status().applied.drive[0], 1000 / 65535.0, 1e-12);  // nothing changed
  EXPECT_EQ(sim.lab().polarisation_in_zone(0)[0], drivers::Polarisation::kParallel);
  EXPECT_EQ(hid_status(*device, command(0x02, hid_state(3000, std::nullopt))), 0x00);  // 17 bytes: unpolarised
  EXPECT_EQ(sim.lab().polarisation_in_zone(0), drivers::PolarisationPerType{});
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
