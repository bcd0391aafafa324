#pragma once
// The members a caller adds to a report (summary.json, the several-camera
// index): a JSON value handed in as is, checked here, written at the file edge.

#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

namespace chromo::maps {

// `extra` as an object (null: none). Throws std::invalid_argument naming
// `what` when it is anything else (e.g. a JSON text passed as a string).
inline nlohmann::ordered_json report_extras(const nlohmann::ordered_json& extra, const char* what) {
  if (extra.is_null()) return nlohmann::ordered_json::object();
  if (!extra.is_object()) throw std::invalid_argument(std::string(what) + " is not a JSON object");
  return extra;
}

}  // namespace chromo::maps
