// How long reading a long session takes, and how much memory (issue 40,
// row 11: a 67 MB journal took 559 MB resident at chromod's start and 2.6 s
// per GetSession, read whole and re-read on every call).
//
// Writes one session folder whose journal holds --frames frame records
// (each as the sequencer writes it: LED state with temperatures, camera
// metadata), then reads it three ways, each after resetting the process's
// peak resident size (/proc/self/clear_refs "5"):
//   whole     the journal read into memory and parsed whole (read_journal,
//             what SessionStore::read_session did before)
//   streamed  SessionStore::read_session (one record at a time)
//   cached    SessionReadCache::get a second time (chromod's GetSession)
// Prints seconds and peak-resident growth for each; writes a chart.
//
//   journal_read_bench [--frames 200000] [--out bench/results/journal_read]
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "bench_cli.hpp"

#include "chart.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/session_read_cache.hpp"
#include "chromo/session/session_store.hpp"
#include "chromo/session/session_timeline.hpp"

namespace {

using namespace chromo;
using Clock = std::chrono::steady_clock;

// VmHWM in MB, after which the peak is reset to the current size.
double peak_resident_mb_then_reset() {
  std::ifstream status("/proc/self/status");
  std::string line;
  double kb = 0;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) kb = std::stod(line.substr(6));
  std::ofstream("/proc/self/clear_refs") << "5";
  return kb / 1024.0;
}

double resident_mb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0;
}

struct Figure {
  double seconds, peak_growth_mb;
};

template <typename Read>
Figure measure(Read read) {
  peak_resident_mb_then_reset();
  const double before = resident_mb();
  const auto start = Clock::now();
  read();
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return {seconds, peak_resident_mb_then_reset() - before};
}

// measure() in a child process of its own, so one way's freed heap does not
// hide the next one's growth.
template <typename Read>
Figure measure_apart(Read read) {
  int pipe_fds[2];
  if (::pipe(pipe_fds) != 0) std::abort();
  const pid_t child = ::fork();
  if (child == 0) {
    const Figure figure = measure(read);
    (void)!::write(pipe_fds[1], &figure, sizeof figure);
    ::_exit(0);
  }
  ::close(pipe_fds[1]);
  Figure figure{-1, -1};
  (void)!::read(pipe_fds[0], &figure, sizeof figure);
  ::close(pipe_fds[0]);
  ::waitpid(child, nullptr, 0);
  return figure;
}

session::SessionPlan one_step_plan() {
  session::SessionPlan plan;
  plan.name = "long";
  plan.steps.resize(1);
  plan.steps[0].name = "w57";
  plan.steps[0].role = session::StepRole::kSubject;
  return plan;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("journal_read_bench: reading a long session's journal, whole, streamed and cached");
  std::size_t frames = 200000;
  std::filesystem::path out = "bench/results/journal_read";
  app.add_option("--frames", frames, "frame records in the journal")->check(CLI::Range(1, 10000000));
  app.add_option("--out", out, "folder for the chart and the scratch session");
  CLI11_PARSE(app, argc, argv);

  const auto root = out / "sessions";
  std::filesystem::remove_all(root);
  std::filesystem::create_directories(root);
  std::string id;
  {
    session::SessionStore store(root, nullptr);
    auto created = store.create(one_step_plan(), "bench", nlohmann::json::object());
    id = created.id;
    session::FrameRecord frame;
    frame.step = "w57";
    frame.camera = "cam0";
    frame.width = 2448;
    frame.height = 2048;
    frame.pixel_format = drivers::PixelFormat::kBayerRG12;
    frame.exposure_us = 12000;
    session::FrameLedState led;
    led.drive[0] = 0.8;
    led.requested_drive[0] = 0.8;
    led.temperature_C.fill(31.25);
    frame.led = led;
    created.journal.reset();
    // Appended without the journal's fsync per record (the bench measures reading).
    std::ofstream journal(root / id / "journal.jsonl", std::ios::app);
    const auto append = [&journal](nlohmann::json record) {
      record["t"] = session::utc_timestamp_now();
      journal << record.dump() << '\n';
    };
    append({{"type", "step_started"}, {"index", 0}});
    for (std::size_t i = 0; i < frames; ++i) {
      frame.index = i;
      frame.sequence = i;
      frame.frame_in_step = static_cast<std::uint32_t>(i);
      frame.file = "frames/w57/cam0-" + std::to_string(i) + ".tiff";
      nlohmann::json record = session::to_json(frame);
      record["type"] = "frame";
      append(std::move(record));
      if (i % 20000 == 0) std::fprintf(stderr, "writing the journal: %zu of %zu frames\r", i, frames);
    }
    append({{"type", "state"}, {"state", "succeeded"}});
  }
  const auto folder = root / id;
  const double journal_mb = static_cast<double>(std::filesystem::file_size(folder / "journal.jsonl")) / 1e6;
  std::printf("journal: %zu frame records, %.1f MB\n", frames, journal_mb);

  session::SessionStore store(root, nullptr);
  std::size_t seen = 0;
  const Figure whole = measure_apart([&] {
    const auto contents = session::read_journal(folder / "journal.jsonl");
    seen = contents.records.size();
    (void)session::session_timeline(contents.records);
  });
  session::SessionReadCache cache;
  const auto read = [&store](const std::filesystem::path& f) { return store.read_session(f); };
  const Figure streamed = measure_apart([&] { seen = cache.get(folder, read).frames.size(); });
  seen = cache.get(folder, read).frames.size();  // chromod's first GetSession fills the cache
  const Figure cached = measure_apart([&] { seen = cache.get(folder, read).frames.size(); });
  std::printf("%-10s %10s %22s\n", "read", "seconds", "peak resident growth MB");
  std::printf("%-10s %10.3f %22.1f\n", "whole", whole.seconds, whole.peak_growth_mb);
  std::printf("%-10s %10.3f %22.1f\n", "streamed", streamed.seconds, streamed.peak_growth_mb);
  std::printf("%-10s %10.3f %22.1f   (%zu frames)\n", "cached", cached.seconds, cached.peak_growth_mb, seen);
  std::printf("streamed/whole: time %.2fx, peak growth %.2fx\n", streamed.seconds / whole.seconds,
              streamed.peak_growth_mb / whole.peak_growth_mb);
  bench::write_bar_chart(out / "journal_read_memory.png",
                         "Reading a " + std::to_string(static_cast<int>(journal_mb)) + " MB journal: peak memory growth",
                         "MB", {{"whole (before)", whole.peak_growth_mb}, {"streamed", streamed.peak_growth_mb},
                                {"cached, again", cached.peak_growth_mb}});
  bench::write_bar_chart(out / "journal_read_seconds.png",
                         "Reading a " + std::to_string(static_cast<int>(journal_mb)) + " MB journal: seconds", "s",
                         {{"whole (before)", whole.seconds}, {"streamed", streamed.seconds}, {"cached, again", cached.seconds}});
  std::filesystem::remove_all(root);
  return 0;
}
