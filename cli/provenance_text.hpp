#pragma once
// A session's provenance (sessions.proto SessionProvenance) as `chromo
// results` and `chromo session show` print it: text lines, or one JSON object.
#include <string>

#include <nlohmann/json.hpp>

#include "chromosphere/v1/sessions.pb.h"

namespace chromo::cli {

// "12 min", "3.2 h", "4.0 days"; "unknown age" for a negative value.
std::string age_text(double seconds);

// "led library: measured 2026-12-06T21:00:00Z (3.2 h before the session), FILE" and
// the lines for the mixes, cameras, plan, operator, study and estimator, each
// after `indent`; one line saying nothing was recorded for an older session.
std::string provenance_text(const chromosphere::v1::SessionProvenance& provenance, const std::string& indent = "");
// The message as protobuf JSON (field names as in the .proto); null when not recorded.
nlohmann::json provenance_json(const chromosphere::v1::SessionProvenance& provenance);

}  // namespace chromo::cli
