#pragma once
// A new empty folder under the system's temporary directory for one test.
#include <unistd.h>

#include <filesystem>
#include <random>
#include <string>

namespace chromo::testing {

inline std::filesystem::path fresh_directory(const std::string& name) {
  auto path = std::filesystem::temp_directory_path() /
              ("chromo-" + name + "-" + std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}()));
  std::filesystem::remove_all(path);
  std::filesystem::create_directories(path);
  return path;
}

}  // namespace chromo::testing
