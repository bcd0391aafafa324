// The project's GigE Vision device side (simulators/camera/gige_vision_device)
// on the real protocol: Aravis (through AravisCamera) against two simulators
// at once, resends under injected loss, reordering and delay, and raw GVCP
// datagrams (malformed, out of range, privilege, heartbeat) from a plain UDP
// socket. No simulator here uses 127.0.0.1.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstring>
#include <iostream>
#include <optional>

#include "camera_fixture.hpp"
#include "chromo/drivers/device_error.hpp"

namespace chromo::testing {
namespace {

using drivers::FrameStatus;
using drivers::PixelFormat;
using std::chrono::milliseconds;

std::unique_ptr<simulators::CameraSimulator> make_simulator(const std::string& serial, int width, int height,
                                                            const simulators::GvspFaultOptions& faults = {}) {
  simulators::CameraSimulatorOptions options;
  options.serial = serial;
  options.sensor_width = width;
  options.sensor_height = height;
  options.faults = faults;
  auto light = std::make_shared<simulators::FixedSpectrumIllumination>(test_irradiance());
  return std::make_unique<simulators::CameraSimulator>(options, light, small_skin_scene());
}

std::unique_ptr<drivers::AravisCamera> open_on(const simulators::CameraSimulator& simulator,
                                               int frame_retention_ms = kTestFrameRetentionMs) {
  drivers::AravisCameraOptions options;
  options.serial = simulator.options().serial;
  options.address = simulator.address();
  options.frame_retention_ms = frame_retention_ms;
  options.socket_buffer_bytes = 8u << 20;
  options.on_warning = [](const std::string&) {};
  return drivers::AravisCamera::open(options);
}

drivers::CameraSettings software_triggered(PixelFormat format, drivers::Roi roi = {}) {
  drivers::CameraSettings s;
  s.pixel_format = format;
  s.roi = roi;
  s.trigger_mode = drivers::TriggerMode::kSoftware;
  return s;
}

// Triggers `count` frames one after another (each waited for) and returns them.
std::vector<drivers::Frame> grab(drivers::AravisCamera& camera, int count) {
  FrameSink sink;
  camera.start_stream(sink.callback());
  for (int i = 0; i < count; ++i) {
    camera.software_trigger();
    if (!sink.wait_for_count(static_cast<std::size_t>(i + 1), milliseconds(8000))) break;
  }
  camera.stop_stream();
  return sink.take();
}

TEST(GigeVisionDevice, TwoSimulatorsOnTheirOwnAddressesStreamAtOnce) {
  auto first = make_simulator("CHROMO-GIGE-A", 128, 96);
  auto second = make_simulator("CHROMO-GIGE-B", 160, 120);
  ASSERT_NE(first->address(), second->address());
  for (const auto* sim : {first.get(), second.get()}) {
    EXPECT_TRUE(sim->address().starts_with("127.77.")) << sim->address();
    EXPECT_NE(sim->address(), "127.0.0.1");
  }
  // A second device on a taken address is refused, naming it.
  simulators::CameraSimulatorOptions clash;
  clash.serial = "CHROMO-CLASH";
  clash.address = first->address();
  try {
    simulators::CameraSimulator taken(clash, std::make_shared<simulators::FixedSpectrumIllumination>(test_irradiance()),
                                      small_skin_scene());
    FAIL() << "two simulators on one address";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(first->address()), std::string::npos) << e.what();
  }

  auto camera_a = open_on(*first);
  auto camera_b = open_on(*second);
  EXPECT_EQ(camera_a->info().serial, "CHROMO-GIGE-A");
  EXPECT_EQ(camera_b->info().serial, "CHROMO-GIGE-B");
  EXPECT_EQ(camera_b->info().sensor_width, 160);
  camera_a->configure(software_triggered(PixelFormat::kMono8));
  camera_b->configure(software_triggered(PixelFormat::kBayerRG12));
  FrameSink sink_a, sink_b;
  camera_a->start_stream(sink_a.callback());
  camera_b->start_stream(sink_b.callback());
  for (std::size_t k = 1; k <= 3; ++k) {
    camera_a->software_trigger();
    camera_b->software_trigger();
    ASSERT_TRUE(sink_a.wait_for_count(k, milliseconds(8000)));
    ASSERT_TRUE(sink_b.wait_for_count(k, milliseconds(8000)));
  }
  camera_a->stop_stream();
  camera_b->stop_stream();
  for (const auto& frame : sink_a.take()) {
    EXPECT_EQ(frame.status, FrameStatus::kComplete);
    EXPECT_EQ(frame.width, 128);
    EXPECT_EQ(frame.data.size(), 128u * 96u);
  }
  for (const auto& frame : sink_b.take()) {
    EXPECT_EQ(frame.status, FrameStatus::kComplete);
    EXPECT_EQ(frame.pixel_format, PixelFormat::kBayerRG12);
    EXPECT_EQ(frame.data.size(), 160u * 120u * 2u);
  }
  EXPECT_EQ(first->device_counters().blocks_sent, 3u);
  EXPECT_EQ(second->device_counters().blocks_sent, 3u);
  EXPECT_EQ(first->frames_rendered(), 3u);
}

TEST(GigeVisionDevice, FivePercentLossOnOneMegapixelFramesIsRecoveredByResends) {
  simulators::GvspFaultOptions faults;
  faults.loss_probability = 0.05;
  faults.seed = 7;
  auto simulator = make_simulator("CHROMO-GIGE-L", 1024, 1024, faults);
  auto camera = open_on(*simulator);
  camera->configure(software_triggered(PixelFormat::kMono8));  // 1 MiB, ~750 packets of 1400 bytes
  const auto frames = grab(*camera, 4);
  ASSERT_EQ(frames.size(), 4u);
  for (const auto& frame : frames) {
    EXPECT_EQ(frame.status, FrameStatus::kComplete);
    EXPECT_EQ(frame.data.size(), 1024u * 1024u);
  }
  const auto device = simulator->device_counters();
  const auto driver = camera->statistics();
  std::cout << "5% loss, 4 x 1 MP Mono8: device sent " << device.packets_sent << " packets, dropped "
            << device.packets_dropped << ", answered " << device.resend_requests_answered << " resend requests with "
            << device.packets_resent << " packets; driver requested " << driver.resend_requests << ", received "
            << driver.resent_packets << " resent, " << driver.missing_packets << " missing\n";
  // About 5% of ~3000 first transmissions lost, every one of them sent again on request.
  EXPECT_GT(device.packets_dropped, 60u);
  EXPECT_LT(device.packets_dropped, 300u);
  EXPECT_GT(device.resend_requests_answered, 0u);
  EXPECT_EQ(device.resend_requests_unavailable, 0u);
  EXPECT_GE(device.packets_resent, device.packets_dropped);
  // The receiver asked for and got every lost packet: complete frames need them all.
  EXPECT_GE(driver.resend_requests, device.packets_dropped);
  EXPECT_GE(driver.resent_packets, device.packets_dropped);
  EXPECT_LE(driver.resent_packets, device.packets_resent);
  EXPECT_EQ(driver.completed, 4u);
  EXPECT_EQ(driver.failed, 0u);
}

TEST(GigeVisionDevice, ReorderedAndDelayedPacketsStillMakeCompleteFrames) {
  simulators::GvspFaultOptions faults;
  faults.reorder_probability = 0.05;
  faults.delay_probability = 0.01;
  faults.delay_us = 3000;
  faults.seed = 11;
  auto simulator = make_simulator("CHROMO-GIGE-R", 512, 512, faults);
  auto camera = open_on(*simulator);
  camera->configure(software_triggered(PixelFormat::kBayerRG16));  // 512 KiB, ~380 packets
  const auto frames = grab(*camera, 4);
  ASSERT_EQ(frames.size(), 4u);
  for (const auto& frame : frames) {
    EXPECT_EQ(frame.status, FrameStatus::kComplete);
    EXPECT_EQ(frame.data.size(), 512u * 512u * 2u);
  }
  const auto device = simulator->device_counters();
  EXPECT_GT(device.packets_reordered, 20u);
  EXPECT_GT(device.packets_delayed, 3u);
  EXPECT_EQ(device.packets_dropped, 0u);
  EXPECT_EQ(camera->statistics().failed, 0u);
}

// A plain UDP socket on 127.0.0.1 speaking GVCP to a simulator.
class RawGvcp {
 public:
  explicit RawGvcp(const std::string& device_address) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in local{};
    local.sin_family = AF_INET;
    local.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof local);
    device_.sin_family = AF_INET;
    device_.sin_port = htons(3956);
    inet_pton(AF_INET, device_address.c_str(), &device_.sin_addr);
  }
  ~RawGvcp() { ::close(fd_); }
  void send(const std::vector<std::uint8_t>& datagram) {
    ::sendto(fd_, datagram.data(), datagram.size(), 0, reinterpret_cast<sockaddr*>(&device_), sizeof device_);
  }
  std::optional<std::vector<std::uint8_t>> receive(int timeout_ms = 1000) {
    pollfd wait{fd_, POLLIN, 0};
    if (::poll(&wait, 1, timeout_ms) <= 0) return std::nullopt;
    std::vector<std::uint8_t> in(2048);
    const ssize_t n = ::recv(fd_, in.data(), in.size(), 0);
    if (n < 0) return std::nullopt;
    in.resize(static_cast<std::size_t>(n));
    return in;
  }
  // A command: key 0x42, ack required, `command`, payload words (big-endian).
  static std::vector<std::uint8_t> command(std::uint16_t command, const std::vector<std::uint32_t>& words,
                                           std::uint16_t id = 7) {
    std::vector<std::uint8_t> out(8 + 4 * words.size());
    out[0] = 0x42;
    out[1] = 0x01;
    put16(&out[2], command);
    put16(&out[4], static_cast<std::uint16_t>(4 * words.size()));
    put16(&out[6], id);
    for (std::size_t i = 0; i < words.size(); ++i) put32(&out[8 + 4 * i], words[i]);
    return out;
  }
  // Sends a command and returns the acknowledge's status (nullopt: no answer).
  std::optional<std::uint16_t> status_of(std::uint16_t command_code, const std::vector<std::uint32_t>& words) {
    send(command(command_code, words));
    const auto ack = receive();
    if (!ack || ack->size() < 8) return std::nullopt;
    return get16(ack->data());
  }
  static void put16(std::uint8_t* at, std::uint16_t v) {
    at[0] = static_cast<std::uint8_t>(v >> 8);
    at[1] = static_cast<std::uint8_t>(v);
  }
  static void put32(std::uint8_t* at, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) at[i] = static_cast<std::uint8_t>(v >> (24 - 8 * i));
  }
  static std::uint16_t get16(const std::uint8_t* at) { return static_cast<std::uint16_t>(at[0] << 8 | at[1]); }
  static std::uint32_t get32(const std::uint8_t* at) {
    return static_cast<std::uint32_t>(at[0]) << 24 | at[1] << 16 | at[2] << 8 | at[3];
  }

 private:
  int fd_ = -1;
  sockaddr_in device_{};
};

constexpr std::uint16_t kDiscovery = 0x0002, kReadReg = 0x0080, kWriteReg = 0x0082, kReadMem = 0x0084,
                        kWriteMem = 0x0086, kPacketResend = 0x0040;

TEST(GigeVisionDevice, DiscoveryAnswersWithTheBootstrapRegisters) {
  auto simulator = make_simulator("CHROMO-GIGE-D", 64, 64);
  RawGvcp gvcp(simulator->address());
  gvcp.send(RawGvcp::command(kDiscovery, {}, 99));
  const auto ack = gvcp.receive();
  ASSERT_TRUE(ack);
  ASSERT_EQ(ack->size(), 8u + 0xF8u);
  EXPECT_EQ(RawGvcp::get16(&(*ack)[0]), 0u);       // success
  EXPECT_EQ(RawGvcp::get16(&(*ack)[2]), 0x0003u);  // DISCOVERY_ACK
  EXPECT_EQ(RawGvcp::get16(&(*ack)[6]), 99u);      // the request's id
  const std::uint8_t* bootstrap = ack->data() + 8;
  in_addr ip{};
  ip.s_addr = htonl(RawGvcp::get32(bootstrap + 0x24));
  EXPECT_EQ(std::string(inet_ntoa(ip)), simulator->address());
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(bootstrap + 0x48)), "Chromosphere");
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(bootstrap + 0xD8)), "CHROMO-GIGE-D");
  // The XML URL points into device memory, and READMEM reads it there.
  gvcp.send(RawGvcp::command(kReadMem, {0x200, 64}));
  const auto url_ack = gvcp.receive();
  ASSERT_TRUE(url_ack);
  ASSERT_EQ(url_ack->size(), 8u + 4u + 64u);
  const std::string url(reinterpret_cast<const char*>(url_ack->data() + 12));
  EXPECT_TRUE(url.starts_with("Local:chromo-camera.xml;100000;")) << url;
  gvcp.send(RawGvcp::command(kReadMem, {0x100000, 8}));
  const auto xml_ack = gvcp.receive();
  ASSERT_TRUE(xml_ack);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(xml_ack->data() + 12), 5), "<?xml");
}

TEST(GigeVisionDevice, MalformedOrOutOfRangeCommandsGetErrorStatusOrAreIgnoredNeverACrash) {
  auto simulator = make_simulator("CHROMO-GIGE-M", 64, 64);
  RawGvcp gvcp(simulator->address());
  const auto before = simulator->device_counters();

  gvcp.send({0x42, 0x01, 0x00});  // shorter than a header
  EXPECT_FALSE(gvcp.receive(300));
  auto bad_key = RawGvcp::command(kReadReg, {0x0934});
  bad_key[0] = 0x43;
  gvcp.send(bad_key);
  EXPECT_FALSE(gvcp.receive(300));
  auto long_length = RawGvcp::command(kReadReg, {0x0934});
  RawGvcp::put16(&long_length[4], 400);  // says 400 bytes, carries 4
  gvcp.send(long_length);
  EXPECT_FALSE(gvcp.receive(300));
  EXPECT_EQ(simulator->device_counters().gvcp_ignored - before.gvcp_ignored, 3u);

  EXPECT_EQ(gvcp.status_of(0x1234, {}), 0x8001);                         // unknown command: not implemented
  EXPECT_EQ(gvcp.status_of(kReadReg, {0x0936}), 0x8005);                 // unaligned address
  EXPECT_EQ(gvcp.status_of(kReadReg, {0x00200000}), 0x8003);             // outside the map
  EXPECT_EQ(gvcp.status_of(kReadReg, {}), 0x8002);                       // no address
  EXPECT_EQ(gvcp.status_of(kReadMem, {0x0000, 1000}), 0x8002);           // count above 536
  EXPECT_EQ(gvcp.status_of(kReadMem, {0x0000, 0}), 0x8002);              // count 0
  EXPECT_EQ(gvcp.status_of(kReadMem, {0x0000, 6}), 0x8005);              // count not whole words
  EXPECT_EQ(gvcp.status_of(kReadMem, {0xFFFFFFF0u, 64}), 0x8003);        // beyond any region (no wrap)
  EXPECT_EQ(gvcp.status_of(kWriteReg, {0x00D8, 0x41414141}), 0x8004);    // serial number: read-only
  EXPECT_EQ(gvcp.status_of(kWriteReg, {0x0D04, 100}), 0x8002);           // packet size below 576
  EXPECT_EQ(gvcp.status_of(kWriteReg, {0x0D18, 0x0A000001}), 0x8002);    // stream to 10.0.0.1: loopback only
  EXPECT_EQ(gvcp.status_of(kWriteReg, {0x10008, 100000}), 0x8002);       // Width beyond the sensor
  EXPECT_EQ(gvcp.status_of(kWriteReg, {0x10000, 5}), 0x8004);            // SensorWidth: read-only
  EXPECT_EQ(gvcp.status_of(kWriteMem, {0x00D9, 0}), 0x8005);             // unaligned memory write
  // Nothing of that changed a register: the stream destination is still unset, Width is still 64.
  gvcp.send(RawGvcp::command(kReadReg, {0x0D18, 0x10008, 0x0D04}));
  const auto values = gvcp.receive();
  ASSERT_TRUE(values);
  ASSERT_EQ(values->size(), 8u + 12u);
  EXPECT_EQ(RawGvcp::get32(values->data() + 8), 0u);
  EXPECT_EQ(RawGvcp::get32(values->data() + 12), 64u);
  EXPECT_EQ(RawGvcp::get32(values->data() + 16), 1400u);
  // A resend request for a block never sent: counted, not answered (no destination yet).
  gvcp.send(RawGvcp::command(kPacketResend, {12, 1, 5}));
  EXPECT_FALSE(gvcp.receive(300));
  EXPECT_EQ(simulator->device_counters().resend_requests_unavailable, 1u);
  EXPECT_GE(simulator->device_counters().gvcp_error_acks - before.gvcp_error_acks, 14u);

  // Still a working camera: Aravis opens it and gets a complete frame.
  auto camera = open_on(*simulator);
  camera->configure(software_triggered(PixelFormat::kMono8));
  const auto frames = grab(*camera, 1);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].status, FrameStatus::kComplete);
}

TEST(GigeVisionDevice, ControlPrivilegeIsExclusiveAndExpiresWithoutHeartbeat) {
  auto simulator = make_simulator("CHROMO-GIGE-P", 64, 64);
  RawGvcp owner(simulator->address()), other(simulator->address());
  EXPECT_EQ(owner.status_of(kWriteReg, {0x0A00, 2}), 0u);       // take control
  EXPECT_EQ(owner.status_of(kWriteReg, {0x0938, 500}), 0u);     // heartbeat timeout 500 ms
  EXPECT_EQ(other.status_of(kWriteReg, {0x0A00, 2}), 0x8006);   // taken
  EXPECT_EQ(other.status_of(kWriteReg, {0x10030, 2000}), 0x8006);
  EXPECT_EQ(other.status_of(kReadReg, {0x0A00}), 0u);           // reading stays open to all
  EXPECT_EQ(owner.status_of(kWriteReg, {0x10030, 2000}), 0u);   // ExposureTime, by the owner
  std::this_thread::sleep_for(milliseconds(1200));               // the owner falls silent
  EXPECT_EQ(simulator->device_counters().control_lost, 1u);
  other.send(RawGvcp::command(kReadReg, {0x0A00}));
  const auto privilege = other.receive();
  ASSERT_TRUE(privilege);
  EXPECT_EQ(RawGvcp::get32(privilege->data() + 8), 0u);
  EXPECT_EQ(other.status_of(kWriteReg, {0x0A00, 2}), 0u);       // free again
}

}  // namespace
}  // namespace chromo::testing
