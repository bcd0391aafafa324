// The Aravis camera driver against the camera simulator, over real GigE
// Vision on 127.0.0.1.
#include <cmath>
#include <cstring>
#include <set>

#include "camera_fixture.hpp"
#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led_controller_factory.hpp"
#include "chromo/simulators/leds/led_controller_simulator.hpp"

namespace chromo::testing {
namespace {

using drivers::DeviceError;
using drivers::FrameStatus;
using drivers::PixelFormat;
using std::chrono::milliseconds;

// 12-bit DN of a 16-bit-container frame (BayerRG16 carries DN << 4).
std::uint16_t dn16(const drivers::Frame& frame, int x, int y) {
  std::uint16_t v;
  std::memcpy(&v, frame.data.data() + 2 * (static_cast<std::size_t>(y) * frame.width + x), 2);
  return v >> 4;
}

// Per-pixel z-scores of a Bayer frame against the noise-free expectation.
struct ZStats {
  double mean = 0, mean_square = 0, max_abs = 0;
};
ZStats bayer_z_scores(const drivers::Frame& frame, const cv::Mat& sensor_response, int x0, int y0,
                      const simulators::CameraModel& model, double exposure_us, double gain_db) {
  ZStats z;
  const double n = static_cast<double>(frame.width) * frame.height;
  for (int y = 0; y < frame.height; ++y)
    for (int x = 0; x < frame.width; ++x) {
      const int sx = x + x0, sy = y + y0;
      const cv::Vec3f r = sensor_response.at<cv::Vec3f>(sy, sx);
      const double response = (sx % 2 == 0 && sy % 2 == 0) ? r[0] : (sx % 2 == 1 && sy % 2 == 1) ? r[2] : r[1];
      const double expected = model.expected_dn(response, exposure_us, gain_db);
      const double sigma = model.noise_sigma_dn(response, exposure_us, gain_db);
      const double score = (dn16(frame, x, y) - expected) / sigma;
      z.mean += score / n;
      z.mean_square += score * score / n;
      z.max_abs = std::max(z.max_abs, std::abs(score));
    }
  return z;
}

TEST_F(CameraOnLoopback, OpensByAddressAndChecksTheSerial) {
  const std::string address = simulator_->address();
  EXPECT_TRUE(address.starts_with("127.77.")) << address;
  const auto info = camera_->info();
  EXPECT_EQ(info.serial, kSerial);
  EXPECT_EQ(info.address, address);
  EXPECT_EQ(info.vendor, "Chromosphere");
  EXPECT_EQ(info.sensor_width, 256);
  EXPECT_EQ(info.sensor_height, 256);
  for (auto format : {PixelFormat::kMono8, PixelFormat::kBayerRG8, PixelFormat::kBayerRG12, PixelFormat::kBayerRG16,
                      PixelFormat::kMono12, PixelFormat::kMono16, PixelFormat::kRgb8})
    EXPECT_NE(std::find(info.pixel_formats.begin(), info.pixel_formats.end(), format), info.pixel_formats.end());

  drivers::AravisCameraOptions options;
  options.serial = "NO-SUCH-CAMERA";
  options.address = address;  // a camera answers there, with another serial
  try {
    drivers::AravisCamera::open(options);
    FAIL() << "opened a camera with another serial";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kRefused);
    EXPECT_NE(std::string(e.what()).find("NO-SUCH-CAMERA"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(kSerial), std::string::npos) << e.what();
  }
  options.address = "127.77.0.0";  // never picked: nothing answers there
  try {
    drivers::AravisCamera::open(options);
    FAIL() << "opened a camera that does not exist";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kNotFound);
    EXPECT_NE(std::string(e.what()).find("127.77.0.0"), std::string::npos) << e.what();
  }
  options.address = "not-an-address";
  EXPECT_THROW(drivers::AravisCamera::open(options), std::invalid_argument);
}

TEST_F(CameraOnLoopback, RejectsSettingsOutsideTheSensorAndKeepsThePreviousOnes) {
  camera_->configure(settings(PixelFormat::kBayerRG8, {0, 0, 128, 128}));
  try {
    camera_->configure(settings(PixelFormat::kBayerRG8, {200, 0, 128, 128}));
    FAIL() << "accepted an ROI outside the sensor";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kInvalidRequest);
  }
  auto bad_exposure = settings(PixelFormat::kBayerRG8);
  bad_exposure.exposure_us = -1;
  EXPECT_THROW(camera_->configure(bad_exposure), DeviceError);
  EXPECT_EQ(camera_->applied_settings().roi.width, 128);
  // Software trigger outside a stream is refused, not sent.
  EXPECT_THROW(camera_->software_trigger(), DeviceError);
}

TEST_F(CameraOnLoopback, WarnsWhenTheSocketBufferIsTooSmallForTheStream) {
  camera_.reset();
  drivers::AravisCameraOptions options;
  options.serial = kSerial;
  options.address = simulator_->address();
  options.frame_retention_ms = kTestFrameRetentionMs;
  options.socket_buffer_bytes = 65536;  // below four 128 KiB frames whatever rmem_max is
  options.on_warning = [this](const std::string& message) {
    std::lock_guard lock(warnings_mutex_);
    warnings_.push_back(message);
  };
  camera_ = drivers::AravisCamera::open(options);
  camera_->configure(settings(PixelFormat::kBayerRG16));
  std::lock_guard lock(warnings_mutex_);
  ASSERT_EQ(warnings_.size(), 1u);
  EXPECT_NE(warnings_[0].find("socket buffer 65536 bytes"), std::string::npos) << warnings_[0];
  EXPECT_NE(warnings_[0].find("net.core.rmem_max"), std::string::npos);
}

TEST_F(CameraOnLoopback, SoftwareTriggeredFramesMatchTheRenderedScene) {
  camera_->configure(settings(PixelFormat::kBayerRG16));
  EXPECT_NEAR(camera_->applied_settings().exposure_us, 10000, 1);
  FrameSink sink;
  camera_->start_stream(sink.callback());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(trigger_and_wait(sink));
  camera_->stop_stream();
  const auto frames = sink.take();
  ASSERT_EQ(frames.size(), 3u);
  const cv::Mat response = simulator_->sensor_response(test_irradiance());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const auto& frame = frames[i];
    EXPECT_EQ(frame.sequence, i);
    ASSERT_EQ(frame.status, FrameStatus::kComplete);
    ASSERT_EQ(frame.width, 256);
    ASSERT_EQ(frame.height, 256);
    ASSERT_EQ(frame.data.size(), 256u * 256u * 2u);
    EXPECT_EQ(frame.pixel_format, PixelFormat::kBayerRG16);
    if (i > 0) {
      EXPECT_EQ(frame.camera_frame_id, frames[i - 1].camera_frame_id + 1);
      EXPECT_GT(frame.camera_timestamp_ns, frames[i - 1].camera_timestamp_ns);
      EXPECT_GE(frame.host_timestamp, frames[i - 1].host_timestamp);
    }
    // Every pixel against the noise model: z-scores of unit variance, none beyond 6 sigma.
    const ZStats z = bayer_z_scores(frame, response, 0, 0, simulator_->camera_model(), 10000, 0);
    EXPECT_NEAR(z.mean, 0.0, 0.03);
    EXPECT_NEAR(z.mean_square, 1.0, 0.06);
    EXPECT_LT(z.max_abs, 6.0);
  }
  const auto stats = camera_->statistics();
  EXPECT_EQ(stats.completed, 3u);
  EXPECT_EQ(stats.failed, 0u);
  EXPECT_EQ(stats.lost_before_driver, 0u);
}

TEST_F(CameraOnLoopback, FramesMatchTheSceneUnderTheLedStateSetOverModbus) {
  // The virtual lab's LEDs instead of the fixed light: the LED driver sets a
  // state over Modbus TCP, the camera simulator renders under the lab's truth.
  camera_.reset();
  simulator_.reset();
  simulators::LedLabOptions lab_options;
  lab_options.start_warm = true;
  lab_options.time_scale = 1e-4;  // freeze warm-up drift for the length of the test
  simulators::LedControllerSimulator leds(lab_options);
  auto led_driver = drivers::make_modbus_tcp_led_controller("127.0.0.1", leds.start_modbus_tcp());
  drivers::LedState state;
  state.drive[spectral::led_type_index(spectral::LedType::kW57)] = 0.8;
  state.drive[spectral::led_type_index(spectral::LedType::kBlue)] = 0.4;
  led_driver->set_state(state);
  led_driver->set_output_enabled(true);

  simulators::CameraSimulatorOptions sim_options;
  sim_options.serial = kSerial;
  sim_options.sensor_width = sim_options.sensor_height = 256;
  const std::shared_ptr<const simulators::SphereIllumination> lab_light(std::shared_ptr<void>(), &leds.lab());
  simulator_ = std::make_unique<simulators::CameraSimulator>(sim_options, lab_light, small_skin_scene());
  drivers::AravisCameraOptions options;
  options.serial = kSerial;
  options.address = simulator_->address();
  options.frame_retention_ms = kTestFrameRetentionMs;
  options.on_warning = [](const std::string&) {};
  camera_ = drivers::AravisCamera::open(options);
  camera_->configure(settings(PixelFormat::kBayerRG16));
  FrameSink sink;
  camera_->start_stream(sink.callback());
  // This test is about the pixels (delivery and its statuses are
  // PacketLoss... and FreeRun...'s business): up to three triggers for one
  // complete frame, every frame accounted for.
  std::vector<drivers::Frame> frames;
  for (int attempt = 0; attempt < 3; ++attempt) {
    ASSERT_TRUE(trigger_and_wait(sink));
    for (auto& f : sink.take()) frames.push_back(std::move(f));
    if (frames.back().status == FrameStatus::kComplete) break;
  }
  camera_->stop_stream();
  ASSERT_EQ(frames.back().status, FrameStatus::kComplete) << frames.size() << " triggers, none complete";
  for (std::size_t i = 0; i + 1 < frames.size(); ++i) EXPECT_EQ(frames[i].status, FrameStatus::kTimeout);
  const ZStats z = bayer_z_scores(frames.back(), simulator_->sensor_response(leds.lab().irradiance_now()), 0, 0,
                                  simulator_->camera_model(), 10000, 0);
  EXPECT_NEAR(z.mean, 0.0, 0.05);
  EXPECT_NEAR(z.mean_square, 1.0, 0.08);
  camera_.reset();
  simulator_.reset();  // before the LED lab it renders under
}

TEST_F(CameraOnLoopback, RoiGainExposureAndIlluminationChangesReachThePixels) {
  // An odd ROI offset shifts the Bayer phase; 6 dB doubles the DN per electron;
  // half the light at twice the exposure gives the same signal.
  auto s = settings(PixelFormat::kBayerRG16, {33, 17, 128, 96});
  s.exposure_us = 20000;
  s.gain_db = 6;
  camera_->configure(s);
  EXPECT_NEAR(camera_->applied_settings().gain_db, 6, 0.01);
  illumination_->set(test_irradiance(0.5));
  FrameSink sink;
  camera_->start_stream(sink.callback());
  ASSERT_TRUE(trigger_and_wait(sink));
  camera_->stop_stream();
  const auto frames = sink.take();
  ASSERT_EQ(frames.size(), 1u);
  ASSERT_EQ(frames[0].status, FrameStatus::kComplete);
  ASSERT_EQ(frames[0].width, 128);
  ASSERT_EQ(frames[0].height, 96);
  const cv::Mat response = simulator_->sensor_response(test_irradiance(0.5));
  const ZStats z = bayer_z_scores(frames[0], response, 33, 17, simulator_->camera_model(), 20000, 6);
  EXPECT_NEAR(z.mean, 0.0, 0.05);
  EXPECT_NEAR(z.mean_square, 1.0, 0.08);
  // The wrong Bayer phase would be far off: the same frame read as if the ROI started at (32, 17).
  const ZStats wrong_phase = bayer_z_scores(frames[0], response, 32, 17, simulator_->camera_model(), 20000, 6);
  EXPECT_GT(wrong_phase.mean_square, 4.0);
}

TEST_F(CameraOnLoopback, HardwareTriggerFramesAndTheLedHookFireOnEachExposure) {
  std::atomic<int> hook_calls{0};
  simulator_->set_exposure_hook([&] { ++hook_calls; });
  auto s = settings(PixelFormat::kMono8, {0, 0, 64, 64});
  s.trigger_mode = drivers::TriggerMode::kHardware;
  camera_->configure(s);
  FrameSink sink;
  camera_->start_stream(sink.callback());
  EXPECT_THROW(camera_->software_trigger(), DeviceError);  // not in software mode
  std::this_thread::sleep_for(milliseconds(300));
  EXPECT_EQ(sink.size(), 0u);  // nothing without an edge
  for (int i = 0; i < 2; ++i) {
    simulator_->pulse_trigger_input();
    ASSERT_TRUE(sink.wait_for_count(i + 1, milliseconds(2000)));
  }
  camera_->stop_stream();
  const auto frames = sink.take();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].sequence, 1u);
  EXPECT_EQ(frames[0].status, FrameStatus::kComplete);
  EXPECT_EQ(frames[0].data.size(), 64u * 64u);
  EXPECT_EQ(hook_calls.load(), 2);
}

TEST_F(CameraOnLoopback, FreeRunDeliversConsecutiveFramesAtTheFrameRateAcrossTheBlockIdWrap) {
  // The fixture's simulator starts its 16-bit block ids at 65400: 150 frames cross 65535 -> 1.
  auto s = settings(PixelFormat::kMono8, {0, 0, 64, 64});
  s.trigger_mode = drivers::TriggerMode::kFreeRun;
  s.frame_rate_hz = 100;
  camera_->configure(s);
  FrameSink sink;
  camera_->start_stream(sink.callback());
  ASSERT_TRUE(sink.wait_for_count(150, milliseconds(15000)));
  camera_->stop_stream();
  const auto frames = sink.take();
  bool wrapped = false;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].sequence, i);
    EXPECT_EQ(frames[i].status, FrameStatus::kComplete);
    if (i > 0) {
      const std::uint64_t previous = frames[i - 1].camera_frame_id;
      EXPECT_EQ(frames[i].camera_frame_id, previous == 0xFFFF ? 1u : previous + 1);
      wrapped = wrapped || previous == 0xFFFF;
    }
  }
  EXPECT_TRUE(wrapped);
  // Mean period from the camera's timestamps, skipping the first (unaligned) frame.
  const double period_ms =
      (frames.back().camera_timestamp_ns - frames[1].camera_timestamp_ns) / 1e6 / static_cast<double>(frames.size() - 2);
  // The simulator paces itself with its own thread's sleeps: on a loaded
  // machine periods stretch, they do not shrink.
  EXPECT_GE(period_ms, 9.5);
  EXPECT_LT(period_ms, 15.0);
  EXPECT_EQ(camera_->statistics().lost_before_driver, 0u);
}

TEST_F(CameraOnLoopback, PacketLossGivesFailedFramesNeverDuplicatesNeverSilentLosses) {
  // Here frames are meant to fail: a short retention keeps the test quick,
  // and each trigger waits well past it, so every frame has completed (or
  // failed) before the next one starts.
  open_camera(500);
  camera_->configure(settings(PixelFormat::kBayerRG8));
  // ~50 packets per frame: about 2 frames in 3 lose one, and this camera
  // (like one without a resend buffer) ignores the resend requests.
  simulators::GvspFaultOptions faults;
  faults.loss_probability = 0.02;
  faults.answer_resend_requests = false;
  simulator_->set_faults(faults);
  FrameSink sink;
  camera_->start_stream(sink.callback());
  constexpr int kTriggers = 24;
  for (int i = 0; i < kTriggers; ++i) trigger_and_wait(sink, milliseconds(2000));
  camera_->stop_stream();
  const auto frames = sink.take();
  const auto stats = camera_->statistics();
  std::set<std::uint64_t> camera_ids;
  std::size_t failed = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].sequence, i);  // consecutive, each once
    // 0: a failed frame whose leader was lost has no trustworthy id.
    if (frames[i].camera_frame_id != 0) {
      EXPECT_TRUE(camera_ids.insert(frames[i].camera_frame_id).second) << "camera frame reported twice";
    }
    if (frames[i].status != FrameStatus::kComplete) {
      ++failed;
      EXPECT_TRUE(frames[i].data.empty());
    } else {
      EXPECT_EQ(frames[i].data.size(), 256u * 256u);
    }
  }
  // Every trigger is accounted for: delivered (complete or failed) or counted as lost.
  EXPECT_EQ(frames.size() + stats.lost_before_driver, static_cast<std::size_t>(kTriggers));
  EXPECT_GT(failed, 0u);
  EXPECT_LT(failed, static_cast<std::size_t>(kTriggers));
  EXPECT_EQ(stats.failed, failed);
  EXPECT_EQ(stats.completed, frames.size() - failed);
  EXPECT_GT(stats.missing_packets, 0u);
}

TEST_F(CameraOnLoopback, ReconnectsAfterTheCameraDisappearsAndRestoresItsSettings) {
  auto s = settings(PixelFormat::kBayerRG16, {64, 32, 128, 96});
  s.exposure_us = 7000;
  s.gain_db = 3;
  camera_->configure(s);
  FrameSink sink;
  camera_->start_stream(sink.callback());
  ASSERT_TRUE(trigger_and_wait(sink));

  simulator_->power_off();  // power cycle: the camera forgets everything
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  while (camera_->link_up() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(milliseconds(50));
  ASSERT_FALSE(camera_->link_up()) << "lost control channel not detected";
  try {
    camera_->software_trigger();
    FAIL() << "trigger accepted while disconnected";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kDisconnected);
  }
  simulator_->power_on();
  while (!camera_->link_up() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(milliseconds(50));
  ASSERT_TRUE(camera_->link_up()) << "no reconnect";
  EXPECT_EQ(camera_->statistics().reconnects, 1u);
  EXPECT_NEAR(camera_->applied_settings().exposure_us, 7000, 1);
  EXPECT_NEAR(camera_->applied_settings().gain_db, 3, 0.01);

  const std::size_t before = sink.size();
  ASSERT_TRUE(trigger_and_wait(sink));
  camera_->stop_stream();
  const auto frames = sink.take();
  ASSERT_GT(frames.size(), before);
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i].sequence, i);
  const auto& last = frames.back();
  ASSERT_EQ(last.status, FrameStatus::kComplete);
  ASSERT_EQ(last.width, 128);
  ASSERT_EQ(last.height, 96);
  // The restored exposure, gain and ROI are what the pixels show.
  const ZStats z = bayer_z_scores(last, simulator_->sensor_response(test_irradiance()), 64, 32,
                                  simulator_->camera_model(), 7000, 3);
  EXPECT_NEAR(z.mean, 0.0, 0.05);
  EXPECT_NEAR(z.mean_square, 1.0, 0.08);
}

}  // namespace
}  // namespace chromo::testing
