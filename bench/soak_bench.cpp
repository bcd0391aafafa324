// soak_bench: sessions back to back on chromod's virtual lab, watching the
// daemon's memory, threads and open files (issue 19, item 8).
//
// Starts chromod as a child process (its own runtime folder, sessions folder
// and table cache under --work), drives it over its Unix socket with the
// API's C++ stubs: StartSession (the standard session), GetOperation until
// the session ends, GetResults until the on-line estimator's maps are there.
// After every session it reads /proc/<pid>/status (VmRSS, Threads) and counts
// /proc/<pid>/fd. Prints a row per session, the figures after the warm-up and
// at the end against the targets (memory ≤ 1.05× the warm-up's; threads and
// descriptors back to the warm-up's counts), writes the rows as CSV and a
// chart (files::draw_chart) into --results.
//
//   soak_bench [--sessions 100] [--warmup 10] [--sensor 640x480] [--work DIR] [--results DIR] [--check]
//
// --sensor: the virtual lab camera's frame (default 640x480, chromod's own
// default camera); the ctest soaks at 320x240 (a quarter of the pixels to
// capture and estimate per session).
// --check: exit status 1 when a target is missed (the ctest, 10 sessions).
// chromod's virtual-lab camera binds a loopback address of its own: no lock.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench_cli.hpp"
#include <grpcpp/grpcpp.h>

#include "chromo/files/gnuplot_chart.hpp"
#include "chromosphere/v1/estimation.grpc.pb.h"
#include "chromosphere/v1/operations.grpc.pb.h"
#include "chromosphere/v1/sessions.grpc.pb.h"

namespace {

namespace fs = std::filesystem;
namespace pb = chromosphere::v1;
using Clock = std::chrono::steady_clock;

struct Sample {
  int sessions = 0;
  double rss_mb = 0;
  int threads = 0;
  int fds = 0;
  double seconds = 0;  // this session, start to results
};

Sample sample_of(pid_t pid) {
  Sample s;
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) s.rss_mb = std::stod(line.substr(6)) / 1024.0;
    if (line.rfind("Threads:", 0) == 0) s.threads = std::stoi(line.substr(8));
  }
  std::error_code error;
  for (fs::directory_iterator it("/proc/" + std::to_string(pid) + "/fd", error), end; !error && it != end;
       it.increment(error))
    ++s.fds;
  return s;
}

pid_t spawn_chromod(const std::string& chromod, const fs::path& work) {
  const std::string log = (work / "chromod.log").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::vector<std::string> arguments{chromod, "--config", (work / "chromod.json").string()};
  std::vector<char*> argv;
  for (auto& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int result = posix_spawn(&pid, chromod.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (result != 0) throw std::runtime_error("cannot start " + chromod);
  return pid;
}

template <class Call>
grpc::Status call(Call&& rpc) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  return rpc(context);
}

bool is_final(pb::OperationState state) {
  return state == pb::OPERATION_STATE_SUCCEEDED || state == pb::OPERATION_STATE_FAILED ||
         state == pb::OPERATION_STATE_CANCELLED || state == pb::OPERATION_STATE_INTERRUPTED;
}

// One standard session and its results; throws naming what went wrong.
void run_session(const std::shared_ptr<grpc::Channel>& channel, int index) {
  auto sessions = pb::SessionService::NewStub(channel);
  auto operations = pb::OperationService::NewStub(channel);
  auto results = pb::ResultsService::NewStub(channel);
  pb::StartSessionRequest request;
  request.set_standard(true);
  request.set_exposure_us(2000);
  request.set_frames_per_camera(1);
  request.set_subject("soak " + std::to_string(index));
  pb::Operation operation;
  auto status = call([&](grpc::ClientContext& c) { return sessions->StartSession(&c, request, &operation); });
  if (!status.ok()) throw std::runtime_error("StartSession: " + status.error_message());
  const auto deadline = Clock::now() + std::chrono::minutes(5);
  while (!is_final(operation.state())) {
    if (Clock::now() > deadline) throw std::runtime_error("session " + operation.id() + " did not end in 5 min");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    pb::GetOperationRequest get;
    get.set_id(operation.id());
    status = call([&](grpc::ClientContext& c) { return operations->GetOperation(&c, get, &operation); });
    if (!status.ok()) throw std::runtime_error("GetOperation: " + status.error_message());
  }
  if (operation.state() != pb::OPERATION_STATE_SUCCEEDED)
    throw std::runtime_error("session " + operation.id() + " ended " + pb::OperationState_Name(operation.state()) +
                             ": " + operation.error());
  pb::Results got;
  do {
    if (Clock::now() > deadline) throw std::runtime_error("session " + operation.id() + ": no results in 5 min");
    pb::GetResultsRequest get;
    get.set_session_id(operation.id());
    status = call([&](grpc::ClientContext& c) { return results->GetResults(&c, get, &got); });
    if (!status.ok()) throw std::runtime_error("GetResults: " + status.error_message());
    if (got.state() == pb::RESULTS_STATE_PENDING) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  } while (got.state() == pb::RESULTS_STATE_PENDING);
  if (got.state() != pb::RESULTS_STATE_AVAILABLE)
    throw std::runtime_error("session " + operation.id() + ": no maps: " + got.reason());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"soak_bench: sessions back to back on chromod's virtual lab; memory, threads, open files"};
  int sessions = 100, warmup = 10;
  std::string chromod = CHROMOD, work = "soak-work", results_dir = CHROMO_BENCH_RESULTS;
  bool check = false, keep = false;
  std::string sensor = "640x480";
  app.add_option("--sessions", sessions, "sessions in all (after the warm-up's)")->check(CLI::Range(2, 100000));
  app.add_option("--warmup", warmup, "sessions before the reference figures")->check(CLI::Range(1, 100000));
  app.add_option("--chromod", chromod, "the chromod to run");
  app.add_option("--work", work, "folder for chromod's runtime files, sessions and table cache (emptied first)");
  app.add_option("--results", results_dir, "where soak_bench.csv and soak_bench.png go");
  app.add_option("--sensor", sensor, "the virtual lab camera's frame, WIDTHxHEIGHT (16-4096 each)");
  app.add_flag("--check", check, "exit 1 when a target is missed");
  app.add_flag("--keep", keep, "keep the work folder");
  CLI11_PARSE(app, argc, argv);
  int sensor_width = 0, sensor_height = 0;
  if (char x = 0; std::sscanf(sensor.c_str(), "%d%c%d", &sensor_width, &x, &sensor_height) != 3 || x != 'x' ||
                  sensor_width < 16 || sensor_width > 4096 || sensor_height < 16 || sensor_height > 4096) {
    std::fprintf(stderr, "soak_bench: --sensor \"%s\": expected WIDTHxHEIGHT, each 16-4096 (e.g. 640x480)\n",
                 sensor.c_str());
    return 2;
  }
  if (warmup >= sessions) {
    std::fprintf(stderr, "soak_bench: --warmup (%d) must be below --sessions (%d)\n", warmup, sessions);
    return 2;
  }
  const fs::path work_dir = fs::absolute(work);
  fs::remove_all(work_dir);
  fs::create_directories(work_dir);
  const fs::path socket = work_dir / "run" / "chromod.sock";
  // The table cache is the work folder's own: the first session builds the
  // tables (the warm-up absorbs it), later ones load or reuse them.
  std::ofstream(work_dir / "chromod.json")
      << "{\"runtime_dir\": \"" << (work_dir / "run").string() << "\", \"sessions_dir\": \""
      << (work_dir / "sessions").string() << "\", \"estimation\": {\"cache_dir\": \"" << (work_dir / "cache").string()
      << "\"}, \"virtual_lab\": {\"cameras\": [{\"name\": \"cam0\", \"sensor_width\": " << sensor_width
      << ", \"sensor_height\": " << sensor_height << "}]}}\n";

  const pid_t pid = spawn_chromod(chromod, work_dir);
  auto stop = [&](int signal) {
    ::kill(pid, signal);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return status;
  };
  std::vector<Sample> samples;
  int exit_code = 0;
  try {
    const auto channel = grpc::CreateChannel("unix:" + socket.string(), grpc::InsecureChannelCredentials());
    if (!channel->WaitForConnected(std::chrono::system_clock::now() + std::chrono::seconds(60)))
      throw std::runtime_error("chromod did not listen within 60 s (see " + (work_dir / "chromod.log").string() + ")");
    Sample start = sample_of(pid);
    std::printf("chromod pid %d listening: %.1f MB, %d threads, %d open files\n", pid, start.rss_mb, start.threads,
                start.fds);
    std::printf("%8s %10s %8s %6s %8s\n", "session", "VmRSS MB", "threads", "fds", "s");
    samples.push_back(start);
    for (int i = 1; i <= sessions; ++i) {
      const auto t = Clock::now();
      run_session(channel, i);
      Sample s = sample_of(pid);
      s.sessions = i;
      s.seconds = std::chrono::duration<double>(Clock::now() - t).count();
      samples.push_back(s);
      std::printf("%8d %10.1f %8d %6d %8.2f%s\n", i, s.rss_mb, s.threads, s.fds, s.seconds,
                  i == warmup ? "   <- after the warm-up" : "");
      std::fflush(stdout);
    }
  } catch (const std::exception& error) {
    std::fprintf(stderr, "soak_bench: %s\n", error.what());
    exit_code = 1;
  }
  const int status = stop(SIGTERM);
  if (exit_code != 0) {
    if (keep) std::fprintf(stderr, "soak_bench: work folder kept: %s\n", work_dir.c_str());
    return exit_code;
  }
  const Sample& reference = samples[static_cast<std::size_t>(warmup)];
  const Sample& last = samples.back();
  const double ratio = last.rss_mb / reference.rss_mb;
  const bool memory_ok = ratio <= 1.05, threads_ok = last.threads <= reference.threads,
             fds_ok = last.fds <= reference.fds;
  std::printf("\nafter the %d-session warm-up: %.1f MB, %d threads, %d open files\n", warmup, reference.rss_mb,
              reference.threads, reference.fds);
  std::printf("after %d sessions:           %.1f MB, %d threads, %d open files\n", sessions, last.rss_mb,
              last.threads, last.fds);
  std::printf("memory %.3fx the warm-up's (target <= 1.05): %s\n", ratio, memory_ok ? "met" : "MISSED");
  std::printf("threads %d vs %d: %s; open files %d vs %d: %s\n", last.threads, reference.threads,
              threads_ok ? "back" : "MORE", last.fds, reference.fds, fds_ok ? "back" : "MORE");
  std::printf("chromod stopped on SIGTERM: %s\n",
              WIFEXITED(status) && WEXITSTATUS(status) == 0 ? "exit 0" : "NOT CLEANLY");

  fs::create_directories(results_dir);
  const fs::path csv = fs::path(results_dir) / "soak_bench.csv";
  {
    std::ofstream out(csv);
    out << "sessions,vmrss_mb,threads,fds,seconds\n";
    for (const auto& s : samples)
      out << s.sessions << "," << s.rss_mb << "," << s.threads << "," << s.fds << "," << s.seconds << "\n";
  }
  chromo::files::GnuplotChart chart;
  chart.png = fs::path(results_dir) / "soak_bench.png";
  std::ostringstream commands;
  commands << "set datafile separator ','\nset key bottom right\nset xlabel 'sessions'\n"
           << "set ylabel 'VmRSS (MB)'\nset y2label 'threads, open files'\nset ytics nomirror\nset y2tics\n"
           << "set yrange [0:*]\nset y2range [0:*]\nset arrow from " << warmup << ", graph 0 to " << warmup
           << ", graph 1 nohead dt 2\n"
           << "set title 'chromod soak: " << sessions << " standard " << sensor
           << " sessions on the virtual lab (warm-up " << warmup << ")'\n"
           << "plot '" << csv.string() << "' using 1:2 skip 1 with linespoints title 'VmRSS (MB)' axes x1y1, \\\n"
           << "     '' using 1:3 skip 1 with lines title 'threads' axes x1y2, \\\n"
           << "     '' using 1:4 skip 1 with lines title 'open files' axes x1y2\n";
  chart.commands = commands.str();
  if (const auto error = chromo::files::draw_chart(chart); !error.empty())
    std::printf("chart: %s\n", error.c_str());
  else
    std::printf("chart: %s, data: %s\n", chart.png.c_str(), csv.c_str());
  if (!keep) fs::remove_all(work_dir);
  if (check && !(memory_ok && threads_ok && fds_ok && WIFEXITED(status) && WEXITSTATUS(status) == 0)) return 1;
  return 0;
}
