// The lab's checks (daemon/internal/operations/lab_checks.hpp, docs/doctor.md)
// on the virtual lab: a healthy lab passes, and each fault chromo doctor knows
// is injected (in a simulator, or in one fact the daemon gathered) and
// reported with its fix.
#include <sys/stat.h>

#include <chrono>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "chromo/daemon/internal/operations/host_facts.hpp"
#include "chromo/daemon/internal/operations/lab_checks.hpp"
#include "chromo/simulators/leds/led_lab.hpp"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

using testing::TestLab;

const CheckResult& find_check(const std::vector<CheckResult>& results, const std::string& id) {
  for (const auto& result : results)
    if (result.id == id) return result;
  throw std::runtime_error("no check " + id);
}

// One virtual lab for the suite (starting one renders its scene).
class LabChecks : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    lab_ = new TestLab("lab-checks");
    daemon_ = lab_->daemon().release();
  }
  static void TearDownTestSuite() {
    delete daemon_;
    delete lab_;
  }
  static inline TestLab* lab_ = nullptr;
  static inline Daemon* daemon_ = nullptr;
};

TEST_F(LabChecks, HealthyVirtualLabPassesEveryDeviceAndStreamCheck) {
  const auto results = daemon_->check_lab();
  for (const std::string id : {"device.sphere", "device.cam0", "device.spec0", "permissions.sessions_dir",
                               "receive_buffer.cam0", "mtu.cam0", "disk"})
    EXPECT_EQ(find_check(results, id).status, CheckStatus::ok) << id << ": " << find_check(results, id).finding;
  // 160x120 BayerRG12 in 16-bit containers, 4 frames in flight, lo's MTU.
  EXPECT_NE(find_check(results, "receive_buffer.cam0").finding.find("for 4 frames of 0.0 MiB"), std::string::npos);
  EXPECT_NE(find_check(results, "mtu.cam0").finding.find("lo reaches 127.77."), std::string::npos);
  // No calibration has run and the configuration names no library.
  EXPECT_EQ(find_check(results, "calibration").status, CheckStatus::warning);
  EXPECT_NE(find_check(results, "calibration").fix.find("chromo calibrate"), std::string::npos);
  for (const auto& result : results)
    if (result.status == CheckStatus::ok) {
      EXPECT_TRUE(result.fix.empty()) << result.id;
    }
}

TEST_F(LabChecks, FactsOfTheLab) {
  const LabFacts facts = daemon_->lab_facts();
  ASSERT_EQ(facts.cameras.size(), 1u);
  EXPECT_EQ(facts.cameras[0].frame_bytes, 160u * 120u * 2u);
  EXPECT_EQ(facts.cameras[0].socket_buffer_bytes, 4u << 20);  // the virtual lab's setting
  EXPECT_EQ(facts.cameras[0].interface_name, "lo");
  // The standard plan at the defaults: 4 frames of the dark and of each of the 3 whites, 1 of each of the 3 subjects.
  EXPECT_EQ(facts.session_bytes, 19u * 160u * 120u * 2u);
  std::ifstream proc("/proc/sys/net/core/rmem_max");
  std::uint64_t rmem_max = 0;
  proc >> rmem_max;
  EXPECT_EQ(facts.host.rmem_max_bytes, rmem_max);
  EXPECT_GT(facts.host.free_disk_bytes.value_or(0), 0u);
}

TEST_F(LabChecks, UnresponsiveLedControllerFailsWithItsFix) {
  lab_->simulators->leds().set_unresponsive(true);
  const auto results = daemon_->check_lab();
  lab_->simulators->leds().set_unresponsive(false);
  const auto& check = find_check(results, "device.sphere");
  EXPECT_EQ(check.status, CheckStatus::failed);
  EXPECT_NE(check.finding.find("does not answer"), std::string::npos) << check.finding;
  EXPECT_NE(check.fix.find("power and network"), std::string::npos) << check.fix;
  EXPECT_EQ(worst_status(results), CheckStatus::failed);
  EXPECT_EQ(find_check(daemon_->check_lab(), "device.sphere").status, CheckStatus::ok);
}

TEST_F(LabChecks, WrongCameraSerialFailsWithItsFix) {
  DeviceConfig camera;
  for (const auto& device : lab_->config.devices)
    if (device.kind == DeviceKind::kCamera) camera = device;
  camera.address = "NO-SUCH-SERIAL";  // the camera alone, at its address, with a wrong serial
  auto devices = builtin_backends().open({camera});
  ASSERT_EQ(devices.cameras.size(), 1u);
  DaemonConfig daemon_config = lab_->config;
  daemon_config.devices = {camera};
  Daemon daemon(daemon_config, std::move(devices));
  const auto results = daemon.check_lab();
  const auto& check = find_check(results, "device.cam0");
  EXPECT_EQ(check.status, CheckStatus::failed);
  EXPECT_NE(check.fix.find("serial is NO-SUCH-SERIAL"), std::string::npos) << check.fix;
  EXPECT_EQ(find_check(results, "receive_buffer.cam0").status, CheckStatus::skipped);
}

TEST_F(LabChecks, PoweredOffCameraFailsOnceItsLinkIsLost) {
  lab_->simulators->camera().power_off();
  auto& camera = testing::aravis(*daemon_);
  for (int i = 0; i < 200 && camera.link_up(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const auto results = daemon_->check_lab();
  lab_->simulators->camera().power_on();
  const auto& check = find_check(results, "device.cam0");
  EXPECT_EQ(check.status, CheckStatus::failed);
  EXPECT_NE(check.finding.find("link is lost"), std::string::npos) << check.finding;
  EXPECT_NE(check.fix.find("power and cable"), std::string::npos) << check.fix;
  for (int i = 0; i < 200 && !camera.link_up(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
}

// Issue 41: LEDs just switched on to full drive are warming (the virtual
// lab's junctions, 300 lab seconds per second: τ = 0.2 s of wall clock) and
// fail with the wait; settled at the new drive, they pass.
TEST_F(LabChecks, LedsJustSwitchedOnAreNotSettledUntilTheyAre) {
  auto& leds = lab_->simulators->leds();
  leds.settle_thermal();
  EXPECT_EQ(find_check(daemon_->check_lab(), "leds_settled.sphere").status, CheckStatus::ok);
  leds.set_output_enabled(true);
  drivers::LedState full;
  full.drive.fill(1.0);
  ASSERT_EQ(leds.apply(full), simulators::LabResult::kOk);
  const auto warming = find_check(daemon_->check_lab(), "leds_settled.sphere");
  leds.settle_thermal();
  const auto settled = find_check(daemon_->check_lab(), "leds_settled.sphere");
  ASSERT_EQ(leds.apply(drivers::LedState{}), simulators::LabResult::kOk);
  leds.set_output_enabled(false);
  leds.settle_thermal();
  EXPECT_EQ(warming.status, CheckStatus::warning) << warming.finding;
  EXPECT_NE(warming.finding.find("warming at"), std::string::npos) << warming.finding;
  EXPECT_NE(warming.fix.find("wait about"), std::string::npos) << warming.fix;
  EXPECT_NE(warming.fix.find("thermal time constant 0.2 s"), std::string::npos) << warming.fix;  // 60 s / 300
  EXPECT_EQ(settled.status, CheckStatus::ok) << settled.finding;
  EXPECT_NE(settled.finding.find("settled: W57 "), std::string::npos) << settled.finding;
}

// Facts of a healthy lab like the virtual one (FactsOfTheLab checks the
// daemon gathers these), for the checks alone: each fault below changes one.
LabFacts healthy_facts() {
  LabFacts facts;
  facts.devices = {{"sphere", "led_controller", "modbus-tcp", "127.0.0.1:1502", true, "", {}, false},
                   {"cam0", "camera", "aravis", "CHROMO-TEST-CAM", true, "", {}, false}};
  CameraStreamFacts camera;
  camera.name = "cam0";
  camera.frame_bytes = 160u * 120u * 2u;
  camera.socket_buffer_bytes = 4u << 20;
  camera.ip_address = "127.77.1.2";
  camera.interface_name = "lo";
  camera.interface_mtu_bytes = 65536;
  facts.cameras = {camera};
  facts.host.rmem_max_bytes = 4u << 20;
  facts.host.free_disk_bytes = 100ull << 30;
  facts.host.clock_synchronised = true;
  facts.host.clock_max_error_us = 1000;
  facts.host.sessions_dir_writable = true;
  facts.host.sessions_dir = "/var/lib/chromosphere/sessions";
  facts.session_bytes = 19u * 160u * 120u * 2u;
  facts.calibration.library_path = "led-library.json";
  facts.calibration.measured_at = facts.now - std::chrono::hours(1);
  return facts;
}

std::vector<CheckResult> checks_with(const std::function<void(LabFacts&)>& fault) {
  LabFacts facts = healthy_facts();
  fault(facts);
  return run_lab_checks(facts);
}

TEST(LabCheckFacts, AHealthyLabPassesEveryCheck) {
  const auto results = run_lab_checks(healthy_facts());
  EXPECT_EQ(results.size(), 8u);  // 2 devices, sessions folder, buffer and MTU of cam0, disk, clock, calibration
  for (const auto& result : results) EXPECT_EQ(result.status, CheckStatus::ok) << result.id << ": " << result.finding;
  EXPECT_EQ(worst_status(results), CheckStatus::ok);
}

TEST(LabCheckFacts, LowRmemMaxWarnsWithTheSysctlItNeeds) {
  const auto results = checks_with([](LabFacts& facts) { facts.host.rmem_max_bytes = 100000; });
  const auto& check = find_check(results, "receive_buffer.cam0");
  EXPECT_EQ(check.status, CheckStatus::warning);
  // 4 frames of 160x120x2 bytes.
  EXPECT_NE(check.fix.find("sysctl -w net.core.rmem_max=153600"), std::string::npos) << check.fix;
  // 5-MP frames at this host's ceiling: the fix asks for 4 of them.
  const auto large = checks_with([](LabFacts& facts) {
    facts.cameras[0].frame_bytes = 2448u * 2048u;
    facts.cameras[0].socket_buffer_bytes = 64u << 20;
    facts.host.rmem_max_bytes = 4u << 20;
  });
  EXPECT_EQ(find_check(large, "receive_buffer.cam0").status, CheckStatus::warning);
  EXPECT_NE(find_check(large, "receive_buffer.cam0").fix.find("net.core.rmem_max=20054016"), std::string::npos);
}

TEST(LabCheckFacts, SmallSocketBufferSettingWarnsNamingTheSetting) {
  const auto results = checks_with([](LabFacts& facts) { facts.cameras[0].socket_buffer_bytes = 65536; });
  EXPECT_EQ(find_check(results, "receive_buffer.cam0").status, CheckStatus::warning);
  EXPECT_NE(find_check(results, "receive_buffer.cam0").fix.find("settings.socket_buffer_bytes to at least 153600"),
            std::string::npos);
}

TEST(LabCheckFacts, MtuWithoutJumboWarnsAndBelowThePacketSizeFails) {
  auto results = checks_with([](LabFacts& facts) {
    facts.cameras[0].interface_name = "eth1";
    facts.cameras[0].interface_mtu_bytes = 1500;
  });
  EXPECT_EQ(find_check(results, "mtu.cam0").status, CheckStatus::warning);
  EXPECT_NE(find_check(results, "mtu.cam0").fix.find("ip link set eth1 mtu 9000"), std::string::npos);
  results = checks_with([](LabFacts& facts) {
    facts.cameras[0].interface_mtu_bytes = 1500;
    facts.cameras[0].packet_size_bytes = 8000;
  });
  EXPECT_EQ(find_check(results, "mtu.cam0").status, CheckStatus::failed);
  EXPECT_NE(find_check(results, "mtu.cam0").finding.find("settings.packet_size_bytes 8000"), std::string::npos);
  results = checks_with([](LabFacts& facts) {
    facts.cameras[0].ip_address = "198.51.100.7";
    facts.cameras[0].interface_name.clear();
    facts.cameras[0].interface_mtu_bytes = 0;
  });
  EXPECT_EQ(find_check(results, "mtu.cam0").status, CheckStatus::failed);
  EXPECT_NE(find_check(results, "mtu.cam0").finding.find("reaches 198.51.100.7"), std::string::npos);
  // The reader itself: no interface of this machine holds TEST-NET-2; loopback is lo's.
  EXPECT_FALSE(interface_reaching("198.51.100.7").has_value());
  ASSERT_TRUE(interface_reaching("127.77.3.4").has_value());
  EXPECT_EQ(interface_reaching("127.77.3.4")->name, "lo");
  EXPECT_FALSE(interface_reaching("not-an-address").has_value());
}

TEST(LabCheckFacts, DiskTooSmallForASessionFailsAndForTenWarns) {
  const LabFacts facts = healthy_facts();
  auto results = checks_with([&](LabFacts& f) { f.host.free_disk_bytes = facts.session_bytes - 1; });
  EXPECT_EQ(find_check(results, "disk").status, CheckStatus::failed);
  EXPECT_NE(find_check(results, "disk").fix.find("chromo session delete"), std::string::npos);
  results = checks_with([&](LabFacts& f) { f.host.free_disk_bytes = facts.session_bytes * 5; });
  EXPECT_EQ(find_check(results, "disk").status, CheckStatus::warning);
  results = checks_with([&](LabFacts& f) { f.storage_limit_bytes = facts.session_bytes / 2; });
  EXPECT_EQ(find_check(results, "disk").status, CheckStatus::failed);
  EXPECT_NE(find_check(results, "disk").finding.find("storage_limit_bytes"), std::string::npos);
}

TEST(LabCheckFacts, UnsynchronisedClockWarns) {
  auto results = checks_with([](LabFacts& f) { f.host.clock_synchronised = false; });
  EXPECT_EQ(find_check(results, "clock").status, CheckStatus::warning);
  EXPECT_NE(find_check(results, "clock").fix.find("timedatectl set-ntp true"), std::string::npos);
  results = checks_with([](LabFacts& f) {
    f.host.clock_synchronised = true;
    f.host.clock_max_error_us = 2'000'000;
  });
  EXPECT_EQ(find_check(results, "clock").status, CheckStatus::warning);
  EXPECT_NE(find_check(results, "clock").finding.find("2000 ms"), std::string::npos);
  results = checks_with([](LabFacts& f) {
    f.host.clock_synchronised = true;
    f.host.clock_max_error_us = 5000;
  });
  EXPECT_EQ(find_check(results, "clock").status, CheckStatus::ok);
}

TEST(LabCheckFacts, OldCalibrationWarnsAndAFreshOnePasses) {
  auto results = checks_with([](LabFacts& f) {
    f.calibration.library_path = "/var/lib/chromosphere/sessions/calibrations/x/led-library.json";
    f.calibration.measured_at = f.now - std::chrono::hours(24 * 45);
  });
  EXPECT_EQ(find_check(results, "calibration").status, CheckStatus::warning);
  EXPECT_NE(find_check(results, "calibration").finding.find("45.0 days old"), std::string::npos);
  results = checks_with([](LabFacts& f) {
    f.calibration.library_path = "led-library.json";
    f.calibration.measured_at = f.now - std::chrono::hours(24 * 2);
  });
  EXPECT_EQ(find_check(results, "calibration").status, CheckStatus::ok);
}

// The rate is (last − first) / interval; the wait τ·ln(rate / limit).
TEST(LabCheckFacts, WarmingLedFailsWithTheWaitAndASteadyOnePasses) {
  LabFacts facts = healthy_facts();
  LedTemperatureFacts leds{"sphere", {"W57", "Blue"}, {30.0, 40.0}, {30.001, 41.0}, 0.5, ""};
  facts.led_temperatures = {leds};
  const auto warming = find_check(run_lab_checks(facts), "leds_settled.sphere");
  EXPECT_EQ(warming.status, CheckStatus::warning);
  // Blue: 1 °C in 0.5 s = 120 °C/min; 60 s · ln(120 / 0.5) = 328.8 s.
  EXPECT_EQ(warming.finding, "Blue warming at 120.0 °C/min (41.0 °C now; settled is below 0.5 °C/min): W57 30.0 °C, Blue 41.0 °C");
  EXPECT_EQ(warming.fix, "wait about 329 s with the LEDs as they are (thermal time constant 60 s), then check again");
  facts.led_temperatures[0].last_C = {30.001, 39.998};  // 0.24 °C/min cooling
  const auto steady = find_check(run_lab_checks(facts), "leds_settled.sphere");
  EXPECT_EQ(steady.status, CheckStatus::ok);
  EXPECT_EQ(steady.finding, "settled: W57 30.0 °C, Blue 40.0 °C (at most 0.24 °C/min over 0.5 s)");
  facts.led_temperatures[0].error = "sphere: timeout";
  EXPECT_EQ(find_check(run_lab_checks(facts), "leds_settled.sphere").status, CheckStatus::skipped);
}

TEST(LabCheckFacts, UnwritableSessionsFolderFails) {
  const auto results = checks_with([](LabFacts& f) { f.host.sessions_dir_writable = false; });
  EXPECT_EQ(find_check(results, "permissions.sessions_dir").status, CheckStatus::failed);
  // The reader: a folder cannot be made below a regular file.
  const auto directory = chromo::testing::fresh_directory("lab-checks-folder");
  std::ofstream(directory / "a-file") << "x";
  EXPECT_FALSE(folder_writable(directory / "a-file" / "sessions"));
  EXPECT_TRUE(folder_writable(directory / "not-yet" / "made"));
  std::filesystem::remove_all(directory);
}

// The spectrometer and the HID controller are found by their ids in sysfs;
// their nodes must be readable and writable by chromod's user (the udev rules).
TEST(LabCheckFacts, DeviceNodesFoundInSysfsAndTheirPermissionsChecked) {
  const auto directory = chromo::testing::fresh_directory("lab-checks-nodes");
  const auto root = directory / "host";
  const auto usb = root / "sys/bus/usb/devices/1-2";
  std::filesystem::create_directories(usb);
  std::ofstream(usb / "idVendor") << "2457\n";
  std::ofstream(usb / "idProduct") << "101e\n";
  std::ofstream(usb / "busnum") << "1\n";
  std::ofstream(usb / "devnum") << "7\n";
  const auto hid = root / "sys/class/hidraw/hidraw3/device";
  std::filesystem::create_directories(hid);
  std::ofstream(hid / "uevent") << "DRIVER=hid-generic\nHID_ID=0003:000016C0:000005DF\nHID_NAME=sphere\n";
  EXPECT_EQ(find_usb_device_node(0x2457, 0x101E, root / "sys", root / "dev"), root / "dev/bus/usb/001/007");
  EXPECT_EQ(find_usb_device_node(0x2457, 0x1002, root / "sys", root / "dev"), std::filesystem::path());
  EXPECT_EQ(find_hidraw_node(0x16c0, 0x05df, root / "sys", root / "dev"), root / "dev/hidraw3");
  EXPECT_EQ(find_hidraw_node(0x16c0, 0x05dc, root / "sys", root / "dev"), std::filesystem::path());

  const auto node = root / "hidraw3";
  std::ofstream(node) << "";
  ::chmod(node.c_str(), 0600);
  if (geteuid() == 0) {
    EXPECT_FALSE(device_node_usable(node));  // root could, the service user could not
  }
  ::chmod(node.c_str(), 0660);
  EXPECT_TRUE(device_node_usable(node));

  DeviceFacts controller{"sphere", "led_controller", "hid", "16c0:05df", true, "", node, false};
  auto results = checks_with([&](LabFacts& f) { f.devices.push_back(controller); });
  EXPECT_EQ(find_check(results, "permissions.sphere").status, CheckStatus::failed);
  EXPECT_NE(find_check(results, "permissions.sphere").fix.find("60-chromosphere.rules"), std::string::npos);
  controller.device_node_usable = true;
  results = checks_with([&](LabFacts& f) { f.devices.push_back(controller); });
  EXPECT_EQ(find_check(results, "permissions.sphere").status, CheckStatus::ok);
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace chromo::daemon
