// chromod's configuration file (daemon/config.hpp, docs/config.md): JSON,
// then every key's type and range (read_config_values; the checks that
// create folders or resolve host names are left out, so the harness touches
// nothing outside the process). Documented error: std::invalid_argument.
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include <nlohmann/json.hpp>

#include "chromo/daemon/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto json = nlohmann::json::parse(std::string_view(reinterpret_cast<const char*>(data), size), nullptr, false);
  if (json.is_discarded()) return 0;
  try {
    (void)chromo::daemon::read_config_values(json, "fuzz.json");
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
