// pipeline_bench: sustained streaming of simulated frames over loopback GigE
// Vision into the daemon's pipeline and storage, and what happened to every
// frame.
//
//   pipeline_bench [--short] [--seconds S] [--dir DIR] [--no-chart]
//
// The link is real: the camera simulator (simulators/, the project's GigE
// Vision device side on its own loopback address 127.77.x.y, rendering a
// white target under a fixed light, or a test pattern) sends GVSP packets (8000-byte jumbo packets: loopback's MTU allows
// them, NOTES.md); the daemon's driver (AravisCamera: Aravis' UDP stream
// receiver, resend requests, the copy into a Frame) receives them; the
// callback hands each complete frame to the real FramePipeline, which writes
// a TIFF and an fsynced journal line per frame (an acknowledged frame). The
// camera free-runs at the frame rate; the measured window starts after the
// stream settled.
//
// Per run: frames due (the camera free-runs at the rate), received complete
// by the driver, stored (acknowledged), lost (due − received; of them, failed:
// incomplete at the driver, gaps: never seen by it),
// unacknowledged (received but not stored: must be 0), packets resent,
// trigger→stored latency, and CPU per stage: the CPU time of every thread of
// this process, grouped by what the thread does (simulator render+send,
// Aravis receive, driver copy/callback, storage). A link-only run (frames
// received and dropped, no storage) separates the link's limit from storage's;
// if 5 MP at 23 fps loses frames, lower rates are tried to find the highest
// rate sustained with zero loss.
//
// Each run's simulator binds an address of its own: no machine-wide lock.
#include <stdexcept>
#include <dirent.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <chrono>
#include <deque>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "chart.hpp"
#include "chromo/daemon/frame_pipeline.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/drivers/camera/aravis_camera.hpp"
#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/camera/fixed_illumination.hpp"
#include "chromo/spectral/cie.hpp"

using namespace chromo;
using Clock = std::chrono::steady_clock;

namespace {

// CPU seconds of every thread of this process, by thread id.
std::map<long, double> thread_cpu_by_tid() {
  std::map<long, double> cpu;
  const double ticks = static_cast<double>(::sysconf(_SC_CLK_TCK));
  DIR* dir = ::opendir("/proc/self/task");
  if (!dir) return cpu;
  while (dirent* entry = ::readdir(dir)) {
    if (entry->d_name[0] == '.') continue;
    std::ifstream stat(std::string("/proc/self/task/") + entry->d_name + "/stat");
    std::string text((std::istreambuf_iterator<char>(stat)), {});
    const auto close = text.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(text.substr(close + 2));
    std::string field;
    double utime = 0, stime = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i) {
      if (i == 14) utime = std::stod(field);
      if (i == 15) stime = std::stod(field);
    }
    cpu[std::stol(entry->d_name)] = (utime + stime) / ticks;
  }
  ::closedir(dir);
  return cpu;
}

long this_tid() { return static_cast<long>(::syscall(SYS_gettid)); }

// Which stage each thread serves, learnt from the callbacks each stage runs
// on; every other thread is Aravis' (stream receive, control, heartbeat).
class StageOfThread {
 public:
  void note(const std::string& stage) {
    std::lock_guard lock(mutex_);
    stages_.emplace(this_tid(), stage);
  }
  std::string operator()(long tid) const {
    std::lock_guard lock(mutex_);
    auto found = stages_.find(tid);
    return found == stages_.end() ? "aravis receive+control (+ pattern camera send)" : found->second;
  }

 private:
  mutable std::mutex mutex_;
  std::map<long, std::string> stages_;
};

enum class Source { kSimulator, kPattern };

struct RunSpec {
  std::string label;
  Source source;
  int width, height;
  double fps;
  double seconds;
  bool store = true;  // false: link only (frames dropped after the driver's copy)
};

struct RunResult {
  RunSpec spec;
  std::uint64_t triggered = 0, received = 0, stored = 0, lost = 0, unacknowledged = 0;
  std::uint64_t failed = 0, gaps = 0;  // of the lost: incomplete at the driver, never seen
  std::uint64_t resent_packets = 0, missing_packets = 0;
  double wall_s = 0, stored_fps = 0, received_mb_per_s = 0;
  double latency_p50_ms = 0, latency_p99_ms = 0, latency_max_ms = 0;
  std::map<std::string, double> cpu_percent_by_stage;  // of one core, over the run
};

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(p * static_cast<double>(values.size() - 1))];
}

RunResult run(const RunSpec& spec, const std::filesystem::path& root, const std::string& serial) {
  simulators::CameraSimulatorOptions camera_options;
  camera_options.serial = serial;
  camera_options.sensor_width = spec.width;
  camera_options.sensor_height = spec.height;
  spectral::Spectrum light = spectral::illuminant_d65();
  light *= 0.8 / light.max();
  auto scene = std::make_shared<const simulators::Scene>(simulators::make_white_target_scene(64, 64));
  StageOfThread stage_of;
  stage_of.note("trigger+main");
  // The pattern camera is the same device side without the scene rendering
  // and camera noise model, whose cost caps the simulator's frame rate
  // (measured by the "simulator" runs).
  camera_options.test_pattern = spec.source == Source::kPattern;
  auto simulator = std::make_unique<simulators::CameraSimulator>(
      camera_options, std::make_shared<simulators::FixedSpectrumIllumination>(light), scene);
  simulator->set_exposure_hook([&stage_of, pattern = camera_options.test_pattern] {
    stage_of.note(pattern ? "pattern camera send" : "simulator render+send");
  });

  drivers::AravisCameraOptions options;
  options.serial = serial;
  options.address = simulator->address();
  options.packet_size_bytes = 8000;  // jumbo packets on loopback
  options.buffer_count = 16;
  options.frame_retention_ms = 500;
  options.on_warning = [](const std::string& warning) { std::cout << "driver warning: " << warning << "\n"; };
  auto camera = drivers::AravisCamera::open(options);
  // Free-running at the frame rate: the simulated camera paces its own
  // exposures, as a camera streaming at line rate does.
  drivers::CameraSettings settings;
  settings.pixel_format = drivers::PixelFormat::kMono8;
  settings.exposure_us = 5000;
  settings.trigger_mode = drivers::TriggerMode::kFreeRun;
  settings.frame_rate_hz = spec.fps;
  camera->configure(settings);

  const auto folder = root / spec.label;
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  session::Journal journal(folder / "journal.jsonl", nullptr);
  std::mutex mutex;
  std::vector<double> latencies_ms;
  std::uint64_t received = 0, failed = 0;
  RunResult result;
  result.spec = spec;
  {
    daemon::FramePipeline pipeline(folder, journal, nullptr, {64, 8}, nullptr, [&](const daemon::StoredFrame& stored) {
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - stored.frame->trigger_time).count();
      stage_of.note("storage (TIFF + fsynced journal)");
      std::lock_guard lock(mutex);
      latencies_ms.push_back(ms);
    });
    std::atomic<bool> counting{false};
    camera->start_stream([&](drivers::Frame&& frame) {
      stage_of.note("driver copy + callback");
      if (!counting) return;  // frames of the start-up, before the measured window
      daemon::CapturedFrame captured;
      // The exposure's start on the steady clock: the camera stamps frames
      // with the host's real time (same machine), so its age is now − stamp.
      const auto age = std::chrono::system_clock::now().time_since_epoch() - std::chrono::nanoseconds(frame.camera_timestamp_ns);
      captured.trigger_time = Clock::now() - (age > std::chrono::seconds(10) || age < std::chrono::seconds(0)
                                                  ? Clock::duration(0)
                                                  : std::chrono::duration_cast<Clock::duration>(age));
      {
        std::lock_guard lock(mutex);
        if (frame.status != drivers::FrameStatus::kComplete) {
          ++failed;
          return;
        }
        ++received;
      }
      if (!spec.store) return;  // link only
      captured.record.camera = "cam0";
      captured.record.step = "stream";
      captured.record.sequence = frame.sequence;
      captured.record.camera_frame_id = frame.camera_frame_id;
      captured.record.camera_timestamp_ns = frame.camera_timestamp_ns;
      captured.record.width = frame.width;
      captured.record.height = frame.height;
      captured.record.pixel_format = frame.pixel_format;
      captured.samples = std::move(frame.data);
      pipeline.submit(std::move(captured));  // blocks while storage's queue is full (never drops)
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // stream settled
    const auto statistics_before = camera->statistics();
    const auto cpu_before = thread_cpu_by_tid();
    const auto start = Clock::now();
    counting = true;
    std::this_thread::sleep_for(std::chrono::duration<double>(spec.seconds));
    counting = false;
    const auto statistics = camera->statistics();
    const auto cpu_after = thread_cpu_by_tid();
    camera->stop_stream();
    pipeline.drain();
    result.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
    for (const auto& [tid, seconds] : cpu_after) {
      const auto before = cpu_before.find(tid);
      const double used = seconds - (before == cpu_before.end() ? 0.0 : before->second);
      if (used > 0) result.cpu_percent_by_stage[stage_of(tid)] += 100.0 * used / spec.seconds;
    }
    const auto counters = pipeline.counters();
    // The camera free-runs at spec.fps: that many frames were due in the
    // window. Lost = due − received complete, whatever the cause; the
    // driver's statistics say how much of it the link saw as incomplete
    // frames (failed) or as gaps in the camera's frame ids.
    result.triggered = static_cast<std::uint64_t>(spec.fps * spec.seconds + 0.5);
    result.received = received;
    result.stored = counters.stored;
    result.lost = result.triggered > received ? result.triggered - received : 0;
    result.failed = failed;
    result.gaps = statistics.lost_before_driver - statistics_before.lost_before_driver;
    result.unacknowledged = spec.store ? received - counters.stored : 0;
    result.resent_packets = statistics.resent_packets - statistics_before.resent_packets;
    result.missing_packets = statistics.missing_packets - statistics_before.missing_packets;
  }
  result.stored_fps = static_cast<double>(spec.store ? result.stored : result.received) / spec.seconds;
  result.received_mb_per_s = static_cast<double>(result.received) * spec.width * spec.height / 1e6 / spec.seconds;
  result.latency_p50_ms = percentile(latencies_ms, 0.5);
  result.latency_p99_ms = percentile(latencies_ms, 0.99);
  result.latency_max_ms = percentile(latencies_ms, 1.0);
  std::filesystem::remove_all(folder);
  return result;
}

void print(const RunResult& r) {
  std::cout << fmt::format("{:<26} {:>6.1f} {:>5} {:>8} {:>7} {:>5} {:>6} {:>5} {:>6} {:>7} {:>8} {:>7.1f} {:>8.1f} {:>8.1f} {:>8.1f}\n",
                           r.spec.label, r.spec.fps, r.triggered, r.received, r.spec.store ? std::to_string(r.stored) : "-",
                           r.lost, r.failed, r.gaps, r.unacknowledged, r.resent_packets, r.missing_packets, r.received_mb_per_s,
                           r.latency_p50_ms, r.latency_p99_ms, r.latency_max_ms);
  std::cout << "    CPU % of one core:";
  for (const auto& [stage, percent] : r.cpu_percent_by_stage)
    if (percent >= 0.5) std::cout << fmt::format("  {} {:.0f}", stage, percent);
  std::cout << "\n";
}

}  // namespace

static int bench_main(int argc, char** argv) {
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
  std::cout << fmt::format("{:<26} {:>6} {:>5} {:>8} {:>7} {:>5} {:>6} {:>5} {:>6} {:>7} {:>8} {:>7} {:>8} {:>8} {:>8}\n",
                           "run", "fps", "due", "received", "stored", "lost", "failed", "gaps", "unack", "resent", "missing",
                           "MB/s", "p50 ms", "p99 ms", "max ms");
  const std::string serial = "CHROMO-BENCH";
  std::vector<RunResult> results;
  if (short_run) {
    // The suite's version: 1 MP Mono8 at 23 fps for 2 s over the pattern
    // camera. Passes when every frame received complete was stored
    // (acknowledged: storage never drops), the link lost at most 5% of the
    // frames the camera sent (failed frames and id gaps: zero on an idle
    // machine; sender and receiver share this process, and another user of
    // the 2 cores can starve the receive thread past the 4 MiB socket
    // buffer), and the camera sent at least half the frames due (its frame
    // clock falls behind under load; those frames are never sent).
    results.push_back(run({"1MP_23fps_pattern", Source::kPattern, 1024, 1024, 23, 2}, dir, serial));
    print(results.back());
    std::filesystem::remove_all(dir);
    const auto& r = results.back();
    const bool ok = r.unacknowledged == 0 && r.stored == r.received && (r.failed + r.gaps) * 20 <= r.received &&
                    r.received * 2 >= r.triggered;
    if (!ok) std::cout << "FAILED: frames unacknowledged, over 5% lost by the link, or the camera sent under half the frames due\n";
    return ok ? 0 : 1;
  }
  // 1 Gb/s carries ~119 MB/s of payload: a 2448x2048 (5 MP) Mono8 frame is
  // 5.0 MB, so ~23 frames/s.
  const int w = 2448, h = 2048;
  // The project's camera simulator (scene under the light, noise model): as fast as it renders.
  results.push_back(run({"5MP_simulator_23fps", Source::kSimulator, w, h, 23, seconds / 2}, dir, serial));
  print(results.back());
  results.push_back(run({"5MP_pattern_link_only", Source::kPattern, w, h, 23, seconds / 2, false}, dir, serial));
  print(results.back());
  results.push_back(run({"5MP_pattern_23fps_stored", Source::kPattern, w, h, 23, seconds}, dir, serial));
  print(results.back());
  // The highest rate sustained with zero loss, if line rate was not.
  double zero_loss_fps = results.back().lost == 0 && results.back().unacknowledged == 0 ? 23 : 0;
  for (double fps : {18.0, 14.0, 10.0, 6.0}) {
    if (zero_loss_fps > 0) break;
    results.push_back(run({fmt::format("5MP_pattern_{:.0f}fps_stored", fps), Source::kPattern, w, h, fps, seconds / 2}, dir, serial));
    print(results.back());
    if (results.back().lost == 0 && results.back().unacknowledged == 0) zero_loss_fps = fps;
  }
  std::filesystem::remove_all(dir);
  const double line_rate_mb = 23 * 2448.0 * 2048 / 1e6;
  std::cout << fmt::format("line rate (1 Gb/s, 5 MP Mono8): {:.1f} MB/s = 23 fps; highest rate run with zero loss: {}\n",
                           line_rate_mb, zero_loss_fps > 0 ? fmt::format("{:.0f} fps", zero_loss_fps) : "none tried");
  const auto& sim = results[0];
  const double sim_cpu = sim.cpu_percent_by_stage.count("simulator render+send") ? sim.cpu_percent_by_stage.at("simulator render+send") : 0.0;
  std::cout << fmt::format("camera simulator: {:.1f} fps delivered of 23 asked; its render+send thread used {:.0f}% of a core "
                           "({:.0f} ms CPU per 5 MP frame delivered)\n",
                           static_cast<double>(sim.received) / sim.spec.seconds, sim_cpu,
                           sim.received ? sim_cpu * 10.0 * sim.spec.seconds / static_cast<double>(sim.received) : 0.0);
  std::cout << fmt::format("pattern camera, link only at 23 fps: {:.1f} MB/s received ({:.2f}x line rate); stored: {:.1f} MB/s\n",
                           results[1].received_mb_per_s, results[1].received_mb_per_s / line_rate_mb,
                           results[2].received_mb_per_s);
  if (chart) {
    auto label = [](std::string text) {  // gnuplot reads '_' as a subscript
      std::replace(text.begin(), text.end(), '_', ' ');
      return text;
    };
    std::vector<bench::Bar> throughput, cpu;
    for (const auto& r : results) throughput.push_back({label(r.spec.label), r.received_mb_per_s});
    throughput.push_back({"1 Gb/s line rate", line_rate_mb});
    for (const auto& [stage, percent] : results[2].cpu_percent_by_stage)
      if (percent >= 0.5) cpu.push_back({stage, percent});
    bench::write_bar_chart(std::filesystem::path(CHROMO_BENCH_RESULTS) / "pipeline_throughput.png",
                           "5 MP Mono8 over loopback GigE Vision: MB/s received complete", "MB/s", throughput);
    bench::write_bar_chart(std::filesystem::path(CHROMO_BENCH_RESULTS) / "pipeline_cpu.png",
                           "CPU per stage at 23 fps, stored (% of one core)", "% of one core", cpu);
    std::vector<bench::Bar> latency;
    for (const auto& r : results)
      if (r.spec.store) latency.push_back({label(r.spec.label) + " p99", r.latency_p99_ms});
    bench::write_bar_chart(std::filesystem::path(CHROMO_BENCH_RESULTS) / "pipeline_latency.png",
                           "Trigger to stored (acknowledged), 99th percentile", "ms", latency);
  }
  return 0;
}

// No exception leaves a program (issue 19): std::invalid_argument (bad input)
// exits 2, anything else 1, each with a message.
int main(int argc, char** argv) {
  try {
    return bench_main(argc, argv);
  } catch (const std::invalid_argument& e) {
    std::cerr << "pipeline_bench: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "pipeline_bench: " << e.what() << "\n";
    return 1;
  } catch (...) {
    std::cerr << "pipeline_bench: unknown exception\n";
    return 1;
  }
}
