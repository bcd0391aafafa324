// chromod's configured devices against an external chromo-sim process, over
// the real protocols (docs/config.md, "Attaching to chromo-sim"): the
// configuration names the modbus-tcp and aravis backends with the addresses
// chromo-sim printed; a session runs end to end, and its results are
// unavailable, naming the setting, when estimation.films_extinction_ratio
// names the virtual lab's films (real devices describe none). Also: what the
// backends say about bad settings and unreachable devices.
#include "../support/chromo_sim_process.hpp"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

using testing::bayer_site_mean;
using chromo::testing::ChromoSimProcess;

TEST(ChromoSimDaemon, ConfiguredRealBackendsRunASessionAgainstChromoSim) {
  ChromoSimProcess sim({"--camera-serial", "CHROMO-SIMDMN", "--sensor-width", "160", "--sensor-height", "120",
                        "--scene-size", "64"});
  const std::string banner = sim.read_until("running");
  const int port = chromo::testing::printed_modbus_port(banner);
  ASSERT_NE(port, -1) << banner;
  const std::string camera_address = chromo::testing::printed_camera_address(banner);
  ASSERT_TRUE(camera_address.starts_with("127.77.")) << banner;

  auto directory = testing::fresh_directory("chromo-sim-daemon");
  nlohmann::json json{
      {"unix_socket", (directory / "s.sock").string()},
      {"sessions_dir", (directory / "sessions").string()},
      {"frame_timeout_ms", 2000},
      // The virtual lab's own films, which real devices do not describe: the
      // session runs, its results are unavailable naming the setting (below).
      {"estimation", {{"films_extinction_ratio", "virtual_lab"}}},
      {"devices",
       {{{"name", "sphere"}, {"kind", "led_controller"}, {"backend", "modbus-tcp"},
         {"address", "127.0.0.1:" + std::to_string(port)}, {"settings", {{"unit_id", 1}, {"response_timeout_ms", 300}}}},
        {{"name", "cam0"}, {"kind", "camera"}, {"backend", "aravis"}, {"address", "CHROMO-SIMDMN"},
         {"settings", {{"pixel_format", "BayerRG12"}, {"ip_address", camera_address}, {"frame_retention_ms", 500},
                       {"socket_buffer_bytes", 4194304}}}}}},
      {"mixes", {{"d65", {{"W57", 0.8}, {"R", 0.05}, {"G", 0.1}, {"B", 0.25}}},
                 {"w57", {{"W57", 0.8}}},
                 {"w57+blue", {{"W57", 0.8}, {"B", 0.4}}}}}};
  const DaemonConfig config = parse_config(json, "test config");
  DeviceSet devices = builtin_backends().open(config.devices);
  ASSERT_TRUE(devices.led_controllers.front()->open_error.empty()) << devices.led_controllers.front()->open_error;
  ASSERT_TRUE(devices.cameras.front()->open_error.empty()) << devices.cameras.front()->open_error;
  {
    Daemon daemon(config, std::move(devices));
    auto reports = daemon.probe_devices();
    ASSERT_EQ(reports.size(), 2u);
    EXPECT_EQ(reports[0].health, DeviceReport::Health::kOk) << reports[0].detail;
    EXPECT_EQ(reports[0].info["model"], "CHROMO-LED6-SIM");
    EXPECT_EQ(reports[1].info["serial"], "CHROMO-SIMDMN");
    auto started = daemon.start_session(testing::quick_standard_plan(1, 2000), "chromo-sim");
    auto final = testing::wait_final(daemon, started.id);
    ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
    EXPECT_EQ(final.counters.stored, 7u);
    auto info = daemon.session(started.id);
    const std::filesystem::path folder = final.folder;
    // chromo-sim rendered under the LED state the daemon set over Modbus:
    // black in the dark step, lit in the others.
    EXPECT_LT(bayer_site_mean(folder / info->frames[0].file, 1), 40.0);
    EXPECT_GT(bayer_site_mean(folder / info->frames[1].file, 1), 100.0);
    EXPECT_EQ(info->results.value("state", ""), "unavailable") << info->results.dump();
    EXPECT_NE(info->results.value("reason", "").find("estimation.films_extinction_ratio \"virtual_lab\": the devices are "
                                                     "not the virtual lab"),
              std::string::npos)
        << info->results.dump();
  }
  // The same controller over its other front-end: Modbus RTU on the pty chromo-sim printed.
  const std::string rtu_key = "Modbus RTU on ";
  const auto rtu_at = banner.find(rtu_key);
  ASSERT_NE(rtu_at, std::string::npos) << banner;
  const std::string pty = banner.substr(rtu_at + rtu_key.size(), banner.find(' ', rtu_at + rtu_key.size()) - rtu_at - rtu_key.size());
  auto rtu_config = parse_config({{"devices", {{{"name", "sphere-rtu"}, {"kind", "led_controller"}, {"backend", "modbus-rtu"},
                                               {"address", pty}, {"settings", {{"baud", 115200}, {"unit_id", 1}}}}}}},
                                 "rtu config");
  DeviceSet rtu = builtin_backends().open(rtu_config.devices);
  ASSERT_NE(rtu.led_controllers.front()->device, nullptr) << pty << ": " << rtu.led_controllers.front()->open_error;
  EXPECT_EQ(rtu.led_controllers.front()->device->info().model, "CHROMO-LED6-SIM");
  EXPECT_EQ(rtu.led_controllers.front()->device->read_status().applied.drive, drivers::DriveLevels{});  // dark after the session
  std::filesystem::remove_all(directory);
}

TEST(ChromoSimDaemon, BadSettingsNameTheFieldAndAnAbsentDeviceIsUnreachable) {
  auto open_one = [](nlohmann::json device) {
    auto config = parse_config({{"devices", nlohmann::json::array({device})}}, "cfg");
    return builtin_backends().open(config.devices);
  };
  auto expect_error = [&](nlohmann::json device, const std::string& start) {
    try {
      open_one(device);
      ADD_FAILURE() << "accepted " << device.dump();
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(start), std::string::npos) << e.what();
    }
  };
  const nlohmann::json led{{"name", "sphere"}, {"kind", "led_controller"}, {"backend", "modbus-tcp"}, {"address", "127.0.0.1:1"}};
  auto with = [](nlohmann::json device, const std::string& key, nlohmann::json value) {
    device["settings"][key] = value;
    return device;
  };
  expect_error(with(led, "unit_idd", 1), "device \"sphere\" (modbus-tcp): settings.unit_idd: unknown");
  expect_error(with(led, "unit_id", 300), "settings.unit_id: 300 is outside [1, 247]");
  expect_error(with(led, "response_timeout_ms", "fast"), "settings.response_timeout_ms: must be an integer");
  auto no_port = led;
  no_port["address"] = "127.0.0.1:http";
  expect_error(no_port, "address: \"127.0.0.1:http\" is not host:port");
  const nlohmann::json camera{{"name", "cam0"}, {"kind", "camera"}, {"backend", "aravis"}, {"address", "NO-SUCH-CAMERA"}};
  expect_error(with(camera, "pixel_format", "Mono9"), "settings.pixel_format: \"Mono9\" unknown");
  expect_error(with(camera, "roi", {{"x", 0}, {"w", 5}}), "settings.roi.w: unknown");
  expect_error(with(camera, "packet_size_bytes", 100), "packet_size_bytes must be 0 or 576-16000");
  const nlohmann::json hid{{"name", "h"}, {"kind", "led_controller"}, {"backend", "hid"}, {"address", "zzzz:0001"}};
  expect_error(hid, "address: vendor id \"zzzz\"");
  const nlohmann::json spectrometer{{"name", "s"}, {"kind", "spectrometer"}, {"backend", "usb"}, {"settings", {{"x", 1}}}};
  expect_error(spectrometer, "settings.x: unknown for this backend (known: none)");
  auto unknown_backend = led;
  unknown_backend["backend"] = "serial-magic";
  expect_error(unknown_backend, "backend \"serial-magic\" is not built in");
  // Valid settings, nobody listening: the device is kept, unreachable, with the driver's error.
  auto set = open_one(with(led, "response_timeout_ms", 100));
  ASSERT_EQ(set.led_controllers.size(), 1u);
  EXPECT_EQ(set.led_controllers.front()->device, nullptr);
  EXPECT_FALSE(set.led_controllers.front()->open_error.empty());
  // A config key inside a device entry that does not exist.
  try {
    parse_config({{"devices", {{{"name", "a"}, {"kind", "camera"}, {"backend", "aravis"}, {"adress", "x"}}}}}, "cfg");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("devices[0].adress: unknown key"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace chromo::daemon
