#include "chromo/files/runtime_dir.hpp"

#include <cstdlib>

namespace chromo::files {

std::filesystem::path default_runtime_dir() {
  if (const char* d = std::getenv("CHROMO_RUNTIME_DIR"); d && *d) return d;
  if (const char* d = std::getenv("XDG_RUNTIME_DIR"); d && *d) return std::filesystem::path(d) / "chromosphere";
  if (const char* d = std::getenv("HOME"); d && *d) return std::filesystem::path(d) / ".local" / "state" / "chromosphere" / "run";
  return {};
}

std::filesystem::path default_unix_socket() {
  const auto dir = default_runtime_dir();
  return dir.empty() ? std::filesystem::path() : dir / "chromod.sock";
}

}  // namespace chromo::files
