#include <gtest/gtest.h>

#include "chromo/daemon/config.hpp"

namespace chromo::daemon {
namespace {

TEST(DaemonConfig, ParsesDevicesAndRefusesBadFieldsByName) {
  auto config = parse_config(nlohmann::json::parse(R"({
    "unix_socket": "/tmp/x.sock", "tcp_address": "127.0.0.1:7443", "token": "0123456789abcdef", "tcp_insecure": true,
    "devices": [{"name": "sphere", "kind": "led_controller", "backend": "modbus-tcp", "address": "127.0.0.1:1502"},
                {"name": "cam0", "kind": "camera", "backend": "aravis", "address": "SN123", "settings": {"gain_db": 3}}],
    "mixes": {"d65": {"W57": 0.5, "B": 0.2}}})"));
  ASSERT_EQ(config.devices.size(), 2u);
  EXPECT_EQ(config.devices[1].kind, DeviceKind::kCamera);
  EXPECT_EQ(config.devices[1].settings["gain_db"], 3);
  EXPECT_DOUBLE_EQ(config.mixes.at("d65")[5], 0.2);

  auto refused = [](const char* text) {
    try {
      parse_config(nlohmann::json::parse(text));
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refused(R"({"tcp_address": "0.0.0.0:1", "token": "short"})").find("token"), std::string::npos);
  // TCP is TLS unless the configuration says insecure, explicitly.
  EXPECT_NE(refused(R"({"tcp_address": "127.0.0.1:1", "token": "0123456789abcdef"})").find("tcp_insecure: TCP without TLS"),
            std::string::npos);
  EXPECT_NE(refused(R"({"tcp_address": "127.0.0.1:1", "token": "0123456789abcdef", "tcp_insecure": true,
                       "tls_certificate_file": "c.pem", "tls_private_key_file": "k.pem"})").find("tcp_insecure: true contradicts"),
            std::string::npos);
  EXPECT_NE(refused(R"({"tcp_address": "127.0.0.1:1", "tcp_insecure": true})").find("token: "), std::string::npos);
  EXPECT_NE(refused(R"({"tcp_insecure": "yes"})").find("tcp_insecure"), std::string::npos);
  EXPECT_NE(refused(R"({"max_streams": 0})").find("max_streams: must be in [1, 1024]"), std::string::npos);
  EXPECT_EQ(parse_config(nlohmann::json::parse("{}")).max_streams, 64u);
  EXPECT_NE(refused(R"({"frame_attempts": "three"})").find("frame_attempts"), std::string::npos);
  EXPECT_NE(refused(R"({"colour": 1})").find("unknown key \"colour\""), std::string::npos);
  EXPECT_NE(refused(R"({"devices": [{"name": "a", "kind": "toaster", "backend": "x"}]})").find("devices[0].kind"),
            std::string::npos);
  EXPECT_NE(refused(R"({"mixes": {"d65": {"UV": 1}}})").find("mixes.d65.UV"), std::string::npos);
}

}  // namespace
}  // namespace chromo::daemon
