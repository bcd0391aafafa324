// chromo-sim end to end: start the process, read where the camera listens,
// grab a frame with the driver over GigE Vision, stop it with SIGINT.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <thread>

#include "camera_fixture.hpp"

extern char** environ;

namespace chromo::testing {
namespace {

class ChromoSimProcess {
 public:
  explicit ChromoSimProcess(std::vector<std::string> args) {
    int pipe_fds[2];
    if (pipe(pipe_fds) != 0) throw std::runtime_error("pipe");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
    args.insert(args.begin(), CHROMO_SIM);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, CHROMO_SIM, &actions, nullptr, argv.data(), environ) != 0)
      throw std::runtime_error("cannot start " CHROMO_SIM);
    posix_spawn_file_actions_destroy(&actions);
    close(pipe_fds[1]);
    out_ = fdopen(pipe_fds[0], "r");
  }
  ~ChromoSimProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    if (out_ != nullptr) fclose(out_);
  }
  // Reads lines until one contains `marker`; returns everything read.
  std::string read_until(const std::string& marker) {
    std::string all;
    char line[512];
    while (fgets(line, sizeof line, out_) != nullptr) {
      all += line;
      if (std::string(line).find(marker) != std::string::npos) break;
    }
    return all;
  }
  int stop_with(int signal_number) {
    kill(pid_, signal_number);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  pid_t pid_ = -1;
  FILE* out_ = nullptr;
};

TEST(ChromoSim, PrintsWhereTheCameraListensServesFramesAndStopsOnCtrlC) {
  ChromoSimProcess sim({"--camera-serial", "CHROMO-SIMTEST", "--sensor-width", "128", "--sensor-height", "128",
                        "--scene-size", "64"});
  const std::string banner = sim.read_until("running");
  EXPECT_NE(banner.find("camera: GigE Vision on 127.0.0.1:3956 serial CHROMO-SIMTEST"), std::string::npos) << banner;
  {
    drivers::AravisCameraOptions options;
    options.serial = "CHROMO-SIMTEST";
    options.socket_buffer_bytes = 1u << 20;
    options.on_warning = [](const std::string&) {};
    auto camera = drivers::AravisCamera::open(options);
    EXPECT_EQ(camera->info().sensor_width, 128);
    drivers::CameraSettings settings;
    settings.pixel_format = drivers::PixelFormat::kBayerRG8;
    camera->configure(settings);
    FrameSink sink;
    camera->start_stream(sink.callback());
    camera->software_trigger();
    ASSERT_TRUE(sink.wait_for_count(1, std::chrono::milliseconds(3000)));
    camera->stop_stream();
    const auto frames = sink.take();
    EXPECT_EQ(frames[0].status, drivers::FrameStatus::kComplete);
    EXPECT_EQ(frames[0].data.size(), 128u * 128u);
  }
  EXPECT_EQ(sim.stop_with(SIGINT), 0);
}

TEST(ChromoSim, BadArgumentsExitWithStatusTwo) {
  ChromoSimProcess sim({"--illuminant", "no-such-light"});
  sim.read_until("never printed");
  EXPECT_EQ(sim.stop_with(0), 2);  // signal 0: just wait for the exit
}

}  // namespace
}  // namespace chromo::testing
