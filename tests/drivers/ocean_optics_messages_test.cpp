// Golden byte sequences of the Ocean Optics USB2000+ command set, written by
// hand from the vendor's command table (as implemented by python-seabreeze
// and printed in the OOI data sheets; sources in docs/protocols/spectrometer.md),
// not from our simulator; and the parsers' rejection of bad input.

#include <gtest/gtest.h>

#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/spectrometer/ocean_optics_messages.hpp"

namespace chromo::drivers::ocean_optics {
namespace {

using Bytes = std::vector<std::uint8_t>;

DeviceError::Kind kind_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const DeviceError& e) {
    return e.kind();
  }
  ADD_FAILURE() << "no DeviceError";
  return DeviceError::Kind::kNotFound;
}

TEST(OceanOpticsGolden, CommandsMatchTheVendorTable) {
  EXPECT_EQ(encode_initialize(), (Bytes{0x01}));
  // 0x02 + integration time in µs as a 32-bit little-endian word: 100 ms = 0x000186A0.
  EXPECT_EQ(encode_set_integration_time(100000), (Bytes{0x02, 0xA0, 0x86, 0x01, 0x00}));
  EXPECT_EQ(encode_set_integration_time(1000), (Bytes{0x02, 0xE8, 0x03, 0x00, 0x00}));
  EXPECT_EQ(encode_set_integration_time(0x12345678), (Bytes{0x02, 0x78, 0x56, 0x34, 0x12}));
  EXPECT_EQ(encode_query_information(0), (Bytes{0x05, 0x00}));   // serial number
  EXPECT_EQ(encode_query_information(1), (Bytes{0x05, 0x01}));   // wavelength c0
  EXPECT_EQ(encode_query_information(14), (Bytes{0x05, 0x0E}));  // non-linearity order
  EXPECT_EQ(encode_request_spectrum(), (Bytes{0x09}));
  EXPECT_EQ(encode_query_status(), (Bytes{0xFE}));
}

TEST(OceanOpticsGolden, ParsesAnInformationReply) {
  Bytes reply{0x05, 0x01, '3', '.', '3', '9', '5', '0', '0', 'e', '+', '0', '2', 0, 0, 0, 0};
  std::string text = parse_information_reply(reply, 1, "dev");
  EXPECT_EQ(text, "3.39500e+02");
  EXPECT_DOUBLE_EQ(parse_information_number(text, 1, "dev"), 339.5);
  Bytes serial{0x05, 0x00, 'U', 'S', 'B', '2', '+', 'F', '0', '1', '2', '3', '4', 0, 0, 0, 0};
  EXPECT_EQ(parse_information_reply(serial, 0, "dev"), "USB2+F01234");
}

TEST(OceanOpticsGolden, ParsesAStatusReply) {
  // pixels 2048 (0x0800 LE), 100 ms, lamp off, trigger mode 0, data ready,
  // 9 packets, powered, packet count 0, reserved, high speed (0x80).
  Bytes reply{0x00, 0x08, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00, 0x01, 0x09, 0x00, 0x00, 0x00, 0x00, 0x80, 0x00};
  SpectrometerStatus status = parse_status_reply(reply, "dev");
  EXPECT_EQ(status.pixel_count, 2048);
  EXPECT_EQ(status.integration_time_us, 100000u);
  EXPECT_FALSE(status.lamp_enabled);
  EXPECT_TRUE(status.data_ready);
}

TEST(OceanOpticsGolden, ParsesASpectrum) {
  Bytes bytes{0x34, 0x12, 0xFF, 0xFF, 0x00, 0x00, 0x69};  // LSB first, then the sync byte
  std::vector<double> counts = parse_spectrum(bytes, 3, "dev");
  EXPECT_EQ(counts, (std::vector<double>{0x1234, 65535, 0}));
}

TEST(OceanOpticsParsers, RejectShortOversizedAndMalformedReplies) {
  Bytes good_info{0x05, 0x01, '1', 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  Bytes short_info(good_info.begin(), good_info.end() - 1);
  Bytes long_info = good_info;
  long_info.push_back(0);
  Bytes wrong_slot = good_info;
  wrong_slot[1] = 2;
  Bytes wrong_echo = good_info;
  wrong_echo[0] = 0x06;
  Bytes binary = good_info;
  binary[3] = 0x07;
  for (const Bytes& bad : {short_info, long_info, wrong_slot, wrong_echo, binary})
    EXPECT_EQ(kind_of([&] { parse_information_reply(bad, 1, "dev"); }), DeviceError::Kind::kProtocol);
  EXPECT_EQ(kind_of([] { parse_information_number("3.3x", 1, "dev"); }), DeviceError::Kind::kProtocol);
  EXPECT_EQ(kind_of([] { parse_information_number("", 1, "dev"); }), DeviceError::Kind::kProtocol);
  EXPECT_EQ(kind_of([] { parse_information_number("1e999", 1, "dev"); }), DeviceError::Kind::kProtocol);

  EXPECT_EQ(kind_of([] { parse_status_reply(Bytes(15, 1), "dev"); }), DeviceError::Kind::kProtocol);
  EXPECT_EQ(kind_of([] { parse_status_reply(Bytes(17, 1), "dev"); }), DeviceError::Kind::kProtocol);
  EXPECT_EQ(kind_of([] { parse_status_reply(Bytes(16, 0), "dev"); }), DeviceError::Kind::kProtocol);  // 0 pixels

  EXPECT_EQ(kind_of([] { parse_spectrum(Bytes{0, 0, 0, 0, 0x69}, 3, "dev"); }), DeviceError::Kind::kProtocol);
  EXPECT_EQ(kind_of([] { parse_spectrum(Bytes{0, 0, 0, 0, 0, 0, 0, 0x69}, 3, "dev"); }), DeviceError::Kind::kProtocol);
  EXPECT_EQ(kind_of([] { parse_spectrum(Bytes{0, 0, 0, 0, 0, 0, 0x68}, 3, "dev"); }), DeviceError::Kind::kProtocol);
  try {
    parse_spectrum(Bytes(100, 0), 2048, "USB2000+ X");
  } catch (const DeviceError& e) {
    EXPECT_NE(std::string(e.what()).find("short spectrum: 100 bytes, expected 4097"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace chromo::drivers::ocean_optics
