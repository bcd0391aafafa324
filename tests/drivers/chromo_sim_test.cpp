// chromo-sim end to end: start the process, read where the camera listens,
// grab a frame with the driver over GigE Vision, stop it with SIGINT.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <fstream>
#include <thread>
#include <tuple>

#include "../support/chromo_sim_process.hpp"
#include "../support/fresh_directory.hpp"
#include "camera_fixture.hpp"
#include "chromo/drivers/led_controller_factory.hpp"

namespace chromo::testing {
namespace {

double mean_of(const drivers::Frame& frame) {
  double sum = 0;
  for (auto v : frame.data) sum += v;
  return sum / static_cast<double>(frame.data.size());
}

// Arms `sequence` hardware-timed (the camera's exposures are the controller's
// trigger input, so frame k after arming shows state k), triggers the camera
// once per state after the first, stops the stream and returns every frame
// it sent (`frames_before` of them taken before). Fewer frames when one timed out.
std::vector<drivers::Frame> run_sequence(drivers::LedController& leds, drivers::AravisCamera& camera, FrameSink& sink,
                                         const std::vector<drivers::LedState>& sequence, std::size_t frames_before) {
  leds.arm_sequence(sequence, drivers::SequenceTrigger::kHardwareRisingEdge);
  leds.set_output_enabled(true);
  for (std::size_t k = 1; k < sequence.size(); ++k) {
    camera.software_trigger();
    // Generous: chromo-sim renders each frame on demand, and the full suite
    // runs two tests at a time on two cores (this test once timed out there).
    if (!sink.wait_for_count(frames_before + k, std::chrono::milliseconds(10000))) break;
  }
  camera.stop_stream();
  return sink.take();
}

TEST(ChromoSim, PrintsWhereDevicesListenServesThemAndStopsOnCtrlC) {
  ChromoSimProcess sim({"--camera-serial", "CHROMO-SIMTEST", "--sensor-width", "128", "--sensor-height", "128",
                        "--scene-size", "64"});
  const std::string banner = sim.read_until("running");
  const std::string camera_address = printed_camera_address(banner);
  EXPECT_TRUE(camera_address.starts_with("127.77.")) << banner;
  EXPECT_NE(banner.find("camera cam0: GigE Vision on " + camera_address + ":3956 serial CHROMO-SIMTEST"), std::string::npos)
      << banner;
  EXPECT_NE(banner.find("Modbus RTU on /dev/pts/"), std::string::npos) << banner;
  const int modbus_port = printed_modbus_port(banner);
  ASSERT_GT(modbus_port, 0) << banner;
  auto leds = drivers::make_modbus_tcp_led_controller("127.0.0.1", modbus_port);
  {
    drivers::AravisCameraOptions options;
    options.serial = "CHROMO-SIMTEST";
    options.address = camera_address;
    options.frame_retention_ms = 2000;  // chromo-sim renders on a loaded 2-core machine (see camera_fixture.hpp)
    options.socket_buffer_bytes = 1u << 20;
    options.on_warning = [](const std::string&) {};
    auto camera = drivers::AravisCamera::open(options);
    EXPECT_EQ(camera->info().sensor_width, 128);
    drivers::CameraSettings settings;
    settings.pixel_format = drivers::PixelFormat::kBayerRG8;
    camera->configure(settings);
    FrameSink sink;
    camera->start_stream(sink.callback());
    // LEDs off: a black frame (black level 16 DN of 4095 = 1 DN in 8 bits).
    camera->software_trigger();
    ASSERT_TRUE(sink.wait_for_count(1, std::chrono::milliseconds(3000)));
    // A hardware-timed LED sequence over the LED controller's Modbus TCP: the
    // camera's exposures are its trigger input, so frame k shows state k.
    std::vector<drivers::LedState> sequence(3);
    sequence[1].drive[spectral::led_type_index(spectral::LedType::kW57)] = 1.0;
    sequence[2].drive[spectral::led_type_index(spectral::LedType::kW57)] = 0.3;
    const auto frames = run_sequence(*leds, *camera, sink, sequence, 1);
    ASSERT_EQ(frames.size(), 3u);
    for (const auto& frame : frames) {
      EXPECT_EQ(frame.status, drivers::FrameStatus::kComplete);
      EXPECT_EQ(frame.data.size(), 128u * 128u);
    }
    EXPECT_LT(mean_of(frames[0]), 2.0);
    EXPECT_GT(mean_of(frames[1]), 20.0);
    // PWM duty keeps the spectrum: 30% drive, 30% signal (above the 1 DN black).
    EXPECT_NEAR((mean_of(frames[2]) - 1.0) / (mean_of(frames[1]) - 1.0), 0.3, 0.04);
    EXPECT_EQ(leds->read_status().sequence_position, 2);
  }
  EXPECT_EQ(sim.stop_with(SIGINT), 0);
}

// Mean of a 16-bit (Mono12 in 16-bit containers) frame over a box, in DN.
double box_mean(const drivers::Frame& frame, int width, int x0, int y0, int x1, int y1) {
  double sum = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const std::size_t i = (static_cast<std::size_t>(y) * width + x) * 2;
      sum += static_cast<double>(frame.data[i] | (frame.data[i + 1] << 8));
    }
  return sum / ((x1 - x0) * (y1 - y0));
}

// --polarisers: the controller reports banks on all six types over Modbus,
// and the camera sees the skin's highlight in the parallel state only while
// the white strip is the same in both (docs/polarisation.md).
TEST(ChromoSim, PolarisersGiveBanksAndACameraThatSeparatesTheHighlight) {
  ChromoSimProcess sim({"--polarisers", "--camera-serial", "CHROMO-SIMPOL", "--sensor-width", "128",
                        "--sensor-height", "128", "--scene-size", "64"});
  const std::string banner = sim.read_until("running");
  auto leds = drivers::make_modbus_tcp_led_controller("127.0.0.1", printed_modbus_port(banner));
  for (bool bank : leds->info().polariser_banks) EXPECT_TRUE(bank);
  drivers::AravisCameraOptions options;
  options.serial = "CHROMO-SIMPOL";
  options.address = printed_camera_address(banner);
  options.frame_retention_ms = 5000;  // the polarised render is the slowest; see run_sequence
  options.socket_buffer_bytes = 1u << 20;
  options.on_warning = [](const std::string&) {};
  auto camera = drivers::AravisCamera::open(options);
  drivers::CameraSettings settings;
  settings.pixel_format = drivers::PixelFormat::kMono12;
  settings.exposure_us = 40000;  // the films pass ~0.18 of the light
  camera->configure(settings);
  FrameSink sink;
  camera->start_stream(sink.callback());
  const int w57 = spectral::led_type_index(spectral::LedType::kW57);
  // Frame k shows state k (the exposure is the controller's trigger input): off, cross, parallel.
  std::vector<drivers::LedState> sequence(3);
  for (std::size_t k = 1; k < 3; ++k) {
    sequence[k].drive[w57] = 1.0;
    sequence[k].polarisation[w57] = k == 1 ? drivers::Polarisation::kCross : drivers::Polarisation::kParallel;
  }
  const auto frames = run_sequence(*leds, *camera, sink, sequence, 0);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(leds->read_status().applied.polarisation[w57], drivers::Polarisation::kParallel);
  // The highlight (scene_added_reflection: 0.3 at (0.65, 0.2) of the patch) and the white strip (the right tenth).
  const double cross_highlight = box_mean(frames[0], 128, 79, 24, 88, 28);
  const double parallel_highlight = box_mean(frames[1], 128, 79, 24, 88, 28);
  const double cross_white = box_mean(frames[0], 128, 118, 8, 126, 120);
  const double parallel_white = box_mean(frames[1], 128, 118, 8, 126, 120);
  std::printf("highlight: cross %.1f DN, parallel %.1f DN; white strip: cross %.1f DN, parallel %.1f DN\n",
              cross_highlight, parallel_highlight, cross_white, parallel_white);
  EXPECT_GT(parallel_highlight, 1.5 * cross_highlight);
  EXPECT_NEAR(parallel_white / cross_white, 1.0, 0.02);
  EXPECT_EQ(sim.stop_with(SIGINT), 0);
}

TEST(ChromoSim, BadArgumentsExitWithStatusTwo) {
  for (std::vector<std::string> args : {std::vector<std::string>{"--fixed-light", "no-such-light"},
                                        std::vector<std::string>{"--sensor-width", "5"},
                                        std::vector<std::string>{"--camera-address", "10.0.0.1"},
                                        std::vector<std::string>{"--no-such-option"},
                                        std::vector<std::string>{"--cameras", "/no/such/cameras.json"},
                                        std::vector<std::string>{"--subsurface", "--subsurface-blue-px", "4",
                                                                 "--subsurface-red-px", "2"}}) {
    ChromoSimProcess sim(args);
    sim.read_until("never printed");
    EXPECT_EQ(sim.stop_with(0), 2) << args[0];  // signal 0: just wait for the exit
  }
}

// chromo-sim --cameras FILE starts every camera of the list (it once started
// only the first), each on its own address, with its own sensor and format.
TEST(ChromoSim, StartsEveryCameraOfTheList) {
  const auto dir = fresh_directory("chromo-sim-cameras");
  std::ofstream(dir / "cameras.json") << R"([
    {"name": "top", "serial": "CHROMO-TOP", "sensor_width": 96, "sensor_height": 64},
    {"name": "side", "serial": "CHROMO-SIDE", "sensor_width": 80, "sensor_height": 48, "pixel_format": "Mono12",
     "pose": {"distance_mm": 300, "azimuth_deg": 25, "focal_length_mm": 1}}])";
  ChromoSimProcess sim({"--cameras", (dir / "cameras.json").string(), "--scene-size", "32"});
  const std::string banner = sim.read_until("running");
  const std::string top = printed_camera_address(banner, "top"), side = printed_camera_address(banner, "side");
  ASSERT_TRUE(top.starts_with("127.77.")) << banner;
  ASSERT_TRUE(side.starts_with("127.77.")) << banner;
  EXPECT_NE(top, side);
  for (const auto& [serial, address, width] :
       {std::tuple{"CHROMO-TOP", top, 96}, std::tuple{"CHROMO-SIDE", side, 80}}) {
    drivers::AravisCameraOptions options;
    options.serial = serial;
    options.address = address;
    options.frame_retention_ms = 2000;
    options.on_warning = [](const std::string&) {};
    auto camera = drivers::AravisCamera::open(options);
    EXPECT_EQ(camera->info().sensor_width, width) << serial;
    drivers::CameraSettings settings;
    settings.pixel_format = drivers::PixelFormat::kMono8;
    camera->configure(settings);
    FrameSink sink;
    camera->start_stream(sink.callback());
    camera->software_trigger();
    EXPECT_TRUE(sink.wait_for_count(1, std::chrono::milliseconds(3000))) << serial;
    camera->stop_stream();
    const auto frames = sink.take();
    ASSERT_FALSE(frames.empty()) << serial;
    EXPECT_EQ(frames[0].width, width) << serial;
  }
  EXPECT_EQ(sim.stop_with(SIGINT), 0);
  std::ofstream(dir / "bad.json") << R"([{"name": "a"}, {"name": "b", "pose": {"azimuth_deg": 120}}])";
  ChromoSimProcess bad({"--cameras", (dir / "bad.json").string()});
  bad.read_until("never printed");
  EXPECT_EQ(bad.stop_with(0), 2);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace chromo::testing
