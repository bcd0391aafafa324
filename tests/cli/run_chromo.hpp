#pragma once
// Runs the real chromo binary (path compiled in as CHROMO_CLI) with a shell
// command line and collects its exit status and output.
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

struct Result {
  int exit_status;
  std::string output;  // stdout and stderr together
};

// `environment`, when given, is prepended to the command ("CHROMO_HOME=/tmp/x").
inline Result run_chromo(const std::string& arguments, const std::string& environment = {}) {
  const std::string command =
      environment + (environment.empty() ? "" : " ") + std::string(CHROMO_CLI) + " " + arguments + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return {-1, "popen failed"};
  std::string output;
  std::array<char, 4096> buffer{};
  while (std::size_t n = fread(buffer.data(), 1, buffer.size(), pipe)) output.append(buffer.data(), n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, output};
}
