#pragma once
// chromo-sim as a child process whose stdout a test reads (drivers_tests and
// daemon_tests; both define CHROMO_SIM as the executable's path). The
// process is killed when the object goes out of scope.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace chromo::testing {

class ChromoSimProcess {
 public:
  explicit ChromoSimProcess(std::vector<std::string> args) {
    int pipe_fds[2];
    if (::pipe(pipe_fds) != 0) throw std::runtime_error("pipe");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
    args.insert(args.begin(), CHROMO_SIM);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int spawned = posix_spawn(&pid_, CHROMO_SIM, &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(pipe_fds[1]);
    if (spawned != 0) {
      ::close(pipe_fds[0]);
      throw std::runtime_error("cannot start " CHROMO_SIM);
    }
    out_ = ::fdopen(pipe_fds[0], "r");
  }
  ChromoSimProcess(const ChromoSimProcess&) = delete;
  ChromoSimProcess& operator=(const ChromoSimProcess&) = delete;
  ~ChromoSimProcess() {
    if (pid_ > 0 && ::kill(pid_, SIGKILL) == 0) ::waitpid(pid_, nullptr, 0);
    if (out_ != nullptr) ::fclose(out_);
  }
  // Reads lines until one contains `marker`; returns everything read.
  std::string read_until(const std::string& marker) {
    std::string all;
    char line[512];
    while (std::fgets(line, sizeof line, out_) != nullptr) {
      all += line;
      if (std::string(line).find(marker) != std::string::npos) break;
    }
    return all;
  }
  // Sends the signal (0: none, just wait) and returns the exit status (-1 if killed).
  int stop_with(int signal_number) {
    ::kill(pid_, signal_number);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  pid_t pid_ = -1;
  FILE* out_ = nullptr;
};

// The Modbus TCP port chromo-sim printed ("... Modbus TCP on 127.0.0.1:<port> ..."), or -1.
inline int printed_modbus_port(const std::string& banner) {
  const std::string key = "Modbus TCP on 127.0.0.1:";
  const auto at = banner.find(key);
  return at == std::string::npos ? -1 : std::stoi(banner.substr(at + key.size()));
}

// The camera simulator's address from "camera: GigE Vision on A:3956 ..."; "" if absent.
// The address chromo-sim printed for camera `name` (its line "camera NAME:
// GigE Vision on A:3956 ..."), the first camera's when name is empty.
inline std::string printed_camera_address(const std::string& banner, const std::string& name = "") {
  const std::string key = ": GigE Vision on ";
  std::size_t at = name.empty() ? banner.find(key) : banner.find("camera " + name + key);
  if (at == std::string::npos) return "";
  if (!name.empty()) at += 7 + name.size();
  const auto begin = at + key.size();
  const auto colon = banner.find(':', begin);
  return colon == std::string::npos ? "" : banner.substr(begin, colon - begin);
}

}  // namespace chromo::testing
