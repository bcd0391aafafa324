// Session plans as JSON (session/session_plan.hpp): what `chromo session run
// --plan FILE` and session.json hold. Documented errors: nlohmann's
// discarded parse (checked), std::invalid_argument naming the field.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "chromo/session/session_plan.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto json = nlohmann::json::parse(data, data + size, nullptr, false);
  if (json.is_discarded()) return 0;
  try {
    const auto plan = chromo::session::plan_from_json(json);
    (void)chromo::session::to_json(plan).dump();
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
