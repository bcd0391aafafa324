#pragma once
// What a session was made with (issue 41): the LED library that gave its
// illuminants, the drive levels of each mix its plan names, the camera
// sensitivities and white target, the plan, the operator and study, and the
// estimator's version and options. chromod fills it when the session starts;
// session.json keeps it under "provenance" (docs/formats/session.md), the
// report (results/summary.json) repeats it, the API and `chromo results`
// show it. A session of an older chromod has none (`recorded` false).
#include <chrono>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "chromo/drivers/led_controller.hpp"

namespace chromo::session {

struct LedLibraryProvenance {
  std::string kind;         // "measured" (a calibration run) or "nominal" (the built-in library)
  std::string file;         // the library file; "" for the built-in one
  std::string created_utc;  // when it was measured (ISO 8601); "" when unknown
  // Seconds from its measurement to the session's start; -1 when unknown.
  double age_at_start_s = -1;
};

struct MixProvenance {
  drivers::DriveLevels drive{};  // indexed by led_type_index()
  // "solved from the LED library" or "configured (mixes)": where the levels came from
  std::string origin;
};

struct SessionProvenance {
  bool recorded = false;  // false: a session written before provenance was recorded
  LedLibraryProvenance led_library;
  std::map<std::string, MixProvenance> mixes;  // each mix a step names ("d65", "w57:1", ...)
  std::string camera_sensitivity;              // every camera's, unless named below
  std::map<std::string, std::string> camera_sensitivity_of;  // camera name → builtin:NAME or CSV
  // Camera name → the subject's width one frame row spans, mm, where the
  // geometry is known (the virtual lab's cameras; docs/maps.md "Scale bar"):
  // the maps' scale bar. A camera not listed has no known scale.
  std::map<std::string, double> camera_field_width_mm;
  double white_reflectance = 0;
  std::string plan;           // the plan's name
  std::string operator_name;  // who ran it (free text, as the request gave it)
  std::string study;          // the study it belongs to (free text)
  std::string estimator_version;                // maps::estimator_version()
  std::map<std::string, std::string> estimator_options;  // method, model, discrepancy, films
};

// Seconds between an ISO 8601 UTC time ("2026-11-22T16:00:00Z", fractions
// ignored) and `now`; -1 when `utc` does not parse.
double seconds_since(const std::string& utc, std::chrono::system_clock::time_point now);

// session.json's "provenance" object and back. Reading is lenient about
// missing keys (they stay empty) and throws std::invalid_argument naming the
// key whose type is wrong.
nlohmann::json to_json(const SessionProvenance& provenance);
SessionProvenance provenance_from_json(const nlohmann::json& json);

}  // namespace chromo::session
