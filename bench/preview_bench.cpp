// The live view's preview path (issue 22): what chromod spends to turn a
// camera frame into a preview update, and how many updates a watcher gets.
//
// Part 1, the conversion side by side on one 5-MP frame (2592×1944, a
// gradient with a clipped patch), CPU time of this thread per update:
//   sampled   daemon::make_preview (preview_image.hpp): one Bayer cell or
//             mono pixel per preview pixel, sRGB, JPEG, histogram, mask;
//   full      the obvious alternative: demosaic the whole frame
//             (cv::cvtColor), resize with area averaging, JPEG-encode;
// for BayerRG12, BayerRG8 and Mono8 at preview widths 320, 480, 640 and
// 1280, and the share of one core at 10 updates/s (target ≤ 10%).
//
// Part 2, end to end: a 5-MP pattern camera (CameraSimulator with
// test_pattern: the device side without scene rendering) over loopback GigE
// Vision through AravisCamera into the daemon's PreviewHub, one watcher at
// 10 updates/s for --seconds: updates delivered per second, the frames the
// camera delivered, and the watcher thread's CPU for converting them (make_
// preview at width 480), as a share of one core.
//
//   preview_bench [--seconds 5] [--out DIR]
//
// Prints its figures; writes DIR/preview.csv and DIR/preview.png (CPU per
// update, sampled against full, per format and width).
#include <time.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include "bench_cli.hpp"
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "chromo/daemon/internal/devices/device_set.hpp"
#include "chromo/daemon/internal/capture/preview_hub.hpp"
#include "chromo/daemon/internal/capture/preview_image.hpp"
#include "chromo/drivers/camera/aravis_camera.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/camera/fixed_illumination.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/spectral/cie.hpp"

namespace {

using namespace chromo;

double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

constexpr int kWidth = 2592, kHeight = 1944;

// A 5-MP frame in `format`: a diagonal gradient over the full scale with a
// clipped square in the middle, as the camera sends it.
std::vector<std::uint8_t> test_frame(drivers::PixelFormat format) {
  const bool sixteen = format == drivers::PixelFormat::kBayerRG12;
  const int full = sixteen ? 4095 : 255;
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(kWidth) * kHeight * (sixteen ? 2 : 1));
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const bool clipped = std::abs(x - kWidth / 2) < 100 && std::abs(y - kHeight / 2) < 100;
      const int value = clipped ? full : static_cast<int>(0.9 * full * (x + y) / (kWidth + kHeight));
      const std::size_t i = static_cast<std::size_t>(y) * kWidth + x;
      if (sixteen) bytes[2 * i] = value & 0xff, bytes[2 * i + 1] = value >> 8;
      else bytes[i] = static_cast<std::uint8_t>(value);
    }
  return bytes;
}

// The full-frame alternative: demosaic (or take grey), area resize, JPEG.
std::size_t full_frame_preview(drivers::PixelFormat format, const std::vector<std::uint8_t>& bytes, int width) {
  const int height = width * kHeight / kWidth;
  cv::Mat rgb;
  if (format == drivers::PixelFormat::kBayerRG12) {
    cv::Mat raw(kHeight, kWidth, CV_16UC1, const_cast<std::uint8_t*>(bytes.data()));
    cv::Mat rgb16;
    cv::cvtColor(raw, rgb16, cv::COLOR_BayerBG2BGR);  // OpenCV names RGGB by its second row
    rgb16.convertTo(rgb, CV_8UC3, 255.0 / 4095.0);
  } else if (format == drivers::PixelFormat::kBayerRG8) {
    cv::cvtColor(cv::Mat(kHeight, kWidth, CV_8UC1, const_cast<std::uint8_t*>(bytes.data())), rgb, cv::COLOR_BayerBG2BGR);
  } else {
    rgb = cv::Mat(kHeight, kWidth, CV_8UC1, const_cast<std::uint8_t*>(bytes.data()));
  }
  cv::Mat small;
  cv::resize(rgb, small, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", small, jpeg, {cv::IMWRITE_JPEG_QUALITY, 80});
  return jpeg.size();
}

struct Row {
  std::string format;
  int width;
  double sampled_ms, full_ms;
};

template <class F>
double cpu_ms_per_call(F&& f, int calls) {
  f();  // warm-up: allocations, code paths
  const double start = thread_cpu_s();
  for (int i = 0; i < calls; ++i) f();
  return 1e3 * (thread_cpu_s() - start) / calls;
}

struct EndToEnd {
  double seconds = 0;
  std::uint64_t updates = 0, camera_frames = 0;
  double convert_cpu_s = 0;
};

EndToEnd end_to_end(double seconds) {
  spectral::Spectrum light = spectral::illuminant_d65();
  light *= 0.8 / light.max();
  auto scene = std::make_shared<const simulators::Scene>(simulators::make_white_target_scene(64, 64));
  simulators::CameraSimulatorOptions camera_options;
  camera_options.serial = "CHROMO-PREVIEW";
  camera_options.sensor_width = kWidth;
  camera_options.sensor_height = kHeight;
  camera_options.test_pattern = true;
  auto simulator = std::make_shared<simulators::CameraSimulator>(
      camera_options, std::make_shared<simulators::FixedSpectrumIllumination>(light), scene);

  drivers::AravisCameraOptions options;
  options.serial = camera_options.serial;
  options.address = simulator->address();
  options.packet_size_bytes = 8000;
  options.buffer_count = 16;
  daemon::DeviceSet devices;
  devices.keep_alive.push_back(simulator);
  auto camera = std::make_unique<daemon::NamedDevice<drivers::Camera>>();
  camera->config.name = "cam0";
  camera->device = drivers::AravisCamera::open(options);
  devices.cameras.push_back(std::move(camera));

  std::atomic<std::uint64_t> camera_frames{0};
  EndToEnd result;
  {
    daemon::PreviewHub hub(devices, [] { return false; });
    daemon::PreviewHub::Watch watch(hub, "cam0", 10.0);
    // Let the free run start and settle, then count.
    for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2); std::chrono::steady_clock::now() < until;)
      watch.next(std::chrono::milliseconds(500));
    const auto start = std::chrono::steady_clock::now();
    std::uint64_t first_serial = 0, last_serial = 0;
    while (std::chrono::steady_clock::now() - start < std::chrono::duration<double>(seconds)) {
      auto frame = watch.next(std::chrono::milliseconds(1000));
      if (!frame) continue;
      if (!first_serial) first_serial = frame->serial;
      last_serial = frame->serial;
      const double cpu = thread_cpu_s();
      const auto& f = frame->frame;
      const daemon::PreviewImage image = daemon::make_preview(f.width, f.height, f.pixel_format, f.data, 480);
      result.convert_cpu_s += thread_cpu_s() - cpu;
      result.updates += !image.jpeg.empty();
    }
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.camera_frames = last_serial - first_serial + 1;
  }
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"the live view's preview path: conversion cost side by side, and updates delivered end to end"};
  double seconds = 5;
  std::string out = "bench/results";
  app.add_option("--seconds", seconds, "end-to-end measurement window")->check(CLI::Range(1.0, 600.0));
  app.add_option("--out", out, "output directory");
  CLI11_PARSE(app, argc, argv);

  std::vector<Row> rows;
  std::printf("preview_bench: one %dx%d frame, CPU of this thread per update (mean of 20)\n", kWidth, kHeight);
  std::printf("%-10s %6s %12s %12s %8s %18s\n", "format", "width", "sampled ms", "full ms", "full/s", "sampled @10/s core");
  for (const auto format : {drivers::PixelFormat::kBayerRG12, drivers::PixelFormat::kBayerRG8, drivers::PixelFormat::kMono8}) {
    const std::vector<std::uint8_t> bytes = test_frame(format);
    const std::string name(drivers::pixel_format_info(format).name);
    for (int width : {320, 480, 640, 1280}) {
      daemon::PreviewImage last;
      const double sampled = cpu_ms_per_call([&] { last = daemon::make_preview(kWidth, kHeight, format, bytes, width); }, 20);
      const double full = cpu_ms_per_call([&] { full_frame_preview(format, bytes, width); }, 20);
      rows.push_back({name, width, sampled, full});
      std::printf("%-10s %6d %12.3f %12.3f %8.1f %17.2f%%  (clipped %u px)\n", name.c_str(), width, sampled, full,
                  full / sampled, sampled * 10 / 1e3 * 100, last.clipped_pixels);
    }
  }

  std::fflush(stdout);
  const EndToEnd e = end_to_end(seconds);
  std::printf("\nend to end: 5-MP Mono8 pattern camera over loopback GigE Vision -> PreviewHub -> one watcher at 10/s, "
              "width 480, %.1f s\n", e.seconds);
  std::printf("  updates delivered %.2f /s (target >= 10), camera frames %.2f /s\n", e.updates / e.seconds,
              e.camera_frames / e.seconds);
  std::printf("  the watcher's conversion: %.2f ms CPU per update, %.2f%% of one core (target <= 10%%)\n",
              e.updates ? 1e3 * e.convert_cpu_s / e.updates : 0.0, 100 * e.convert_cpu_s / e.seconds);

  const std::filesystem::path dir = out;
  std::filesystem::create_directories(dir);
  {
    std::ofstream csv(dir / "preview.csv");
    csv << "format,width,sampled_ms,full_ms\n";
    for (const Row& r : rows) csv << r.format << "," << r.width << "," << r.sampled_ms << "," << r.full_ms << "\n";
  }
  {
    std::ofstream dat(dir / "preview.dat");
    for (const Row& r : rows) dat << '"' << r.format << " " << r.width << "\" " << r.sampled_ms << " " << r.full_ms << "\n";
  }
  files::GnuplotChart chart;
  chart.png = dir / "preview.png";
  chart.terminal = "pngcairo size 1000,520 font 'DejaVu Sans,10'";
  chart.commands = "set title 'Preview update from one 5-MP frame: CPU ms, sampled (chromod) against full-frame demosaic + resize'\n"
                   "set style data histograms\nset style histogram clustered gap 1\nset style fill solid 0.8 border -1\n"
                   "set logscale y\nset ylabel 'CPU ms per update (log)'\nset grid ytics\nset xtics rotate by -30\n"
                   "plot '" + (dir / "preview.dat").string() + "' using 2:xtic(1) title 'sampled (make\\_preview)', '' using 3 title 'full frame'\n";
  if (const std::string failed = files::draw_chart(chart, dir / "preview.gp"); !failed.empty())
    std::fprintf(stderr, "chart: %s\n", failed.c_str());
  std::printf("wrote %s and %s\n", (dir / "preview.csv").c_str(), chart.png.c_str());
  return e.updates > 0 ? 0 : 1;
}
