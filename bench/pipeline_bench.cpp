// pipeline_bench: sustained frame streaming into the daemon's pipeline and
// storage (TIFF + fsynced journal per frame, the real FramePipeline and files).
//
//   pipeline_bench [--short] [--seconds S] [--dir DIR] [--no-chart]
//
// Not a Google Benchmark micro-benchmark: the question is whether a rate is
// sustained for a whole run, so each run streams frames on a fixed schedule
// (the camera's) and reports what happened to every one of them.
//
// The producer stands in for the camera link: at each scheduled trigger it
// copies a rendered frame into a fresh buffer (the receive copy) and submits
// it. Like a GigE Vision driver with a pool of kCameraBuffers buffers, it
// cannot wait: a frame whose trigger comes while more than kCameraBuffers
// frames are still unsubmitted is lost ("camera_buffer_overrun").
//
// What is NOT measured here yet: the GigE Vision packets themselves (per-packet
// cost, resends), because the Aravis camera driver and its loopback simulator
// are not on main; see README.md.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <iostream>
#include <numeric>
#include <random>
#include <thread>

#include <fmt/format.h>

#include "chart.hpp"
#include "chromo/daemon/frame_pipeline.hpp"
#include "chromo/daemon/journal.hpp"

using namespace chromo;
using Clock = std::chrono::steady_clock;

namespace {

constexpr int kCameraBuffers = 16;

double thread_cpu_ms() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) * 1e3 + static_cast<double>(now.tv_nsec) * 1e-6;
}

struct RunSpec {
  std::string label;
  int width, height;
  double fps;  // 0 = as fast as storage takes them
  double seconds;
};

struct RunResult {
  RunSpec spec;
  std::uint64_t triggered = 0, stored = 0, lost = 0, unacknowledged = 0;
  double wall_s = 0, stored_fps = 0, stored_mb_per_s = 0;
  double latency_p50_ms = 0, latency_p99_ms = 0, latency_max_ms = 0;
  double copy_cpu_ms_per_frame = 0, storage_cpu_ms_per_frame = 0;
};

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(p * static_cast<double>(values.size() - 1))];
}

RunResult run(const RunSpec& spec, const std::filesystem::path& root) {
  const auto folder = root / spec.label;
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  daemon::Journal journal(folder / "journal.jsonl", nullptr);
  std::mutex latency_mutex;
  std::vector<double> latencies_ms;
  daemon::FramePipeline pipeline(folder, journal, nullptr, {64, 8}, nullptr, [&](const daemon::StoredFrame& stored) {
    double ms = std::chrono::duration<double, std::milli>(Clock::now() - stored.frame->trigger_time).count();
    std::lock_guard lock(latency_mutex);
    latencies_ms.push_back(ms);
  });

  const std::size_t bytes = static_cast<std::size_t>(spec.width) * spec.height;
  std::vector<std::uint8_t> rendered(bytes);
  std::mt19937 random(1);
  for (auto& b : rendered) b = static_cast<std::uint8_t>(random());

  RunResult result{spec};
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration<double>(spec.seconds);
  const auto period = spec.fps > 0 ? std::chrono::duration<double>(1.0 / spec.fps) : std::chrono::duration<double>(0);
  const double cpu_before = thread_cpu_ms();
  double copy_cpu_ms = 0;
  for (std::uint64_t k = 0;; ++k) {
    auto trigger = start + std::chrono::duration_cast<Clock::duration>(period * static_cast<double>(k));
    if (trigger >= end || (spec.fps == 0 && Clock::now() >= end)) break;
    std::this_thread::sleep_until(trigger);
    ++result.triggered;
    // The camera's buffer pool: a frame whose trigger passed more than
    // kCameraBuffers periods ago could not have been received.
    if (spec.fps > 0 && Clock::now() - trigger > period * kCameraBuffers) {
      pipeline.record_lost("camera_buffer_overrun");
      continue;
    }
    const double copy_start = thread_cpu_ms();
    daemon::CapturedFrame captured;
    captured.camera = "cam0";
    captured.step = "stream";
    captured.frame.sequence = k;
    captured.frame.camera_frame_id = k + 1;
    captured.frame.width = spec.width;
    captured.frame.height = spec.height;
    captured.frame.pixel_format = drivers::PixelFormat::kMono8;
    captured.frame.host_timestamp = std::chrono::system_clock::now();
    captured.frame.data = rendered;
    captured.frame.data[0] = static_cast<std::uint8_t>(k);
    captured.trigger_time = spec.fps > 0 ? trigger : Clock::now();
    copy_cpu_ms += thread_cpu_ms() - copy_start;
    pipeline.submit(std::move(captured));
  }
  (void)cpu_before;
  pipeline.drain();
  result.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  auto counters = pipeline.counters();
  result.stored = counters.stored;
  result.lost = counters.lost;
  result.unacknowledged = result.triggered - result.stored - result.lost;
  result.stored_fps = static_cast<double>(result.stored) / result.wall_s;
  result.stored_mb_per_s = result.stored_fps * static_cast<double>(bytes) / 1e6;
  result.latency_p50_ms = percentile(latencies_ms, 0.5);
  result.latency_p99_ms = percentile(latencies_ms, 0.99);
  result.latency_max_ms = counters.max_trigger_to_stored_ms;
  result.copy_cpu_ms_per_frame = copy_cpu_ms / std::max<double>(1, static_cast<double>(result.triggered - result.lost));
  result.storage_cpu_ms_per_frame = counters.storage_cpu_ms / std::max<double>(1, static_cast<double>(result.stored));
  std::filesystem::remove_all(folder);
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  bool short_run = false, chart = true;
  double seconds = 20;
  std::filesystem::path dir = std::filesystem::temp_directory_path() / ("chromo-pipeline-bench-" + std::to_string(::getpid()));
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--short") short_run = true;
    else if (arg == "--no-chart") chart = false;
    else if (arg == "--seconds" && i + 1 < argc) seconds = std::stod(argv[++i]);
    else if (arg == "--dir" && i + 1 < argc) dir = argv[++i];
    else {
      std::cerr << "usage: pipeline_bench [--short] [--seconds S] [--dir DIR] [--no-chart]\n";
      return 2;
    }
  }
  // 1 Gb/s carries ~119 MB/s of payload: a 2448x2048 (5 MP) Mono8 frame is
  // 5.0 MB, so ~23 frames/s.
  std::vector<RunSpec> specs;
  if (short_run) {
    specs = {{"1MP_23fps", 1024, 1024, 23, 2}};
    chart = false;
  } else {
    specs = {{"1MP_23fps", 1024, 1024, 23, seconds / 2},
             {"5MP_23fps_line_rate", 2448, 2048, 23, seconds},
             {"5MP_unthrottled", 2448, 2048, 0, seconds / 2}};
  }
  std::vector<RunResult> results;
  std::cout << fmt::format("{:<22} {:>9} {:>7} {:>5} {:>6} {:>9} {:>8} {:>9} {:>9} {:>9} {:>10} {:>11}\n", "run", "triggered",
                           "stored", "lost", "unack", "fps", "MB/s", "p50 ms", "p99 ms", "max ms", "copy ms/f", "store ms/f");
  for (const auto& spec : specs) {
    auto r = run(spec, dir);
    results.push_back(r);
    std::cout << fmt::format("{:<22} {:>9} {:>7} {:>5} {:>6} {:>9.2f} {:>8.1f} {:>9.1f} {:>9.1f} {:>9.1f} {:>10.2f} {:>11.2f}\n",
                             spec.label, r.triggered, r.stored, r.lost, r.unacknowledged, r.stored_fps, r.stored_mb_per_s,
                             r.latency_p50_ms, r.latency_p99_ms, r.latency_max_ms, r.copy_cpu_ms_per_frame,
                             r.storage_cpu_ms_per_frame);
  }
  std::filesystem::remove_all(dir);
  if (!short_run && results.size() == 3) {
    const double line_rate_mb = 23 * 2448.0 * 2048 / 1e6;
    std::cout << fmt::format("storage headroom at 5 MP: unthrottled {:.1f} MB/s = {:.2f}x the 1 Gb/s line rate ({:.1f} MB/s)\n",
                             results[2].stored_mb_per_s, results[2].stored_mb_per_s / line_rate_mb, line_rate_mb);
    std::cout << fmt::format("storage CPU per 5 MP frame: {:.2f} ms ({:.0f}% of one core at 23 fps); copy {:.2f} ms\n",
                             results[1].storage_cpu_ms_per_frame, results[1].storage_cpu_ms_per_frame * 23 / 10,
                             results[1].copy_cpu_ms_per_frame);
  }
  if (chart) {
    std::vector<bench::Bar> throughput, latency;
    for (const auto& r : results) {
      throughput.push_back({r.spec.label, r.stored_mb_per_s});
      latency.push_back({r.spec.label + " p99", r.latency_p99_ms});
    }
    throughput.push_back({"1 Gb/s line rate", 23 * 2448.0 * 2048 / 1e6});
    bench::write_bar_chart(std::filesystem::path(CHROMO_BENCH_RESULTS) / "pipeline_throughput.png",
                           "Frames stored (TIFF + fsynced journal), sustained", "MB/s", throughput);
    bench::write_bar_chart(std::filesystem::path(CHROMO_BENCH_RESULTS) / "pipeline_latency.png",
                           "Trigger to stored (acknowledged), 99th percentile", "ms", latency);
  }
  bool clean = true;
  for (const auto& r : results) clean = clean && (r.spec.fps == 0 || (r.lost == 0 && r.unacknowledged == 0));
  if (!clean) std::cout << "FRAMES LOST OR UNACKNOWLEDGED at a scheduled rate\n";
  return clean ? 0 : 1;
}
