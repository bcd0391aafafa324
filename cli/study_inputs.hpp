#pragma once
// What a study session's maps depend on, as one content hash (docs/study.md
// "Resuming"): a session whose record holds the hash of its current inputs is
// done and is not estimated again.
//
// The hash (FNV-1a 64, files/fnv1a.hpp) covers, in order: the estimator's
// version (estimator_version()), the study's estimation options
// (options_json()), and the bytes and relative paths of every input file of
// the session: session.json, journal.jsonl, frames/**, the session's own LED
// libraries (results/led_library*.json), the LED library and camera
// sensitivity CSVs the options name, the region masks (study_regions.hpp).
// Not covered: what the session's folder holds beside them (derived/,
// chromod's maps in results/).
//
// Thread rules: free functions.

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "session_estimate.hpp"
#include "study_regions.hpp"

namespace chromo::cli::study {

// The estimation options a study fixes for every session, as JSON (the
// table's options column, study.json's "options"): method, model,
// neighbourhood_flags, order_pooling, led_library, camera, camera_of,
// white_reflectance. Not threads or the table cache: the maps do not depend
// on them.
nlohmann::ordered_json options_json(const EstimateOptions& options, const std::vector<RegionSpec>& regions = {});
// The inverse of options_json (study.json read back); std::invalid_argument naming the member.
EstimateOptions options_from_json(const nlohmann::json& json);

// maps::estimator_version() (chromo/maps/estimator_version.hpp), as chromod records it.
std::string estimator_version();

// The inputs' hash (16 hex digits). Throws std::runtime_error naming a file
// that cannot be read.
// With regions, their masks' bytes too (region_input_files()).
std::string input_hash(const std::filesystem::path& session_folder, const EstimateOptions& options,
                       const std::string& version, const std::vector<RegionSpec>& regions = {});

}  // namespace chromo::cli::study
