#pragma once
// A study's output folder (docs/study.md):
//
//   DIR/study.json               the study: format, sessions (name, folder), estimation options
//   DIR/sessions/<name>/         a session's maps, exactly as `chromo estimate SESSION_DIR --out` writes them
//   DIR/records/<name>.json      a session's record: state (done, failed), error, the inputs' hash, who
//                                estimated it (run, task, host), seconds, and one row per camera
//   DIR/tasks/<run>[-<task>].json  a run's (or a Slurm task's) own progress record
//   DIR/study.csv                the study table (study_table.hpp)
//   DIR/slurm/                   the sbatch script, the task lists, the job's ids, the tasks' logs
//   DIR/hold                     while it exists, runs and tasks wait before their next session
//
// Every file is written durably (files/durable_file.hpp): a temporary name
// unique across hosts, fsync, rename. A session's maps are estimated into
// DIR/sessions/.tmp-<host>-<pid>-<name>/ and renamed to their place before
// its record is written, so a record never points at partial maps.
//
// Thread rules: free functions; one writer per session at a time.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "session_estimate.hpp"
#include "study_manifest.hpp"
#include "study_regions.hpp"

namespace chromo::cli::study {

inline constexpr const char* kStudyFormat = "chromosphere-study/1";

struct Study {
  std::filesystem::path dir;  // absolute
  std::vector<ManifestSession> sessions;
  EstimateOptions options;  // the estimation options (input, out, threads, cache_dir unused)
  std::vector<RegionSpec> regions;  // the table's region masks (study_regions.hpp)
  const ManifestSession* find(const std::string& name) const;
};

// std::invalid_argument unless `dir` is absent, an empty directory or a
// study folder (it has study.json).
void check_output_folder(const std::filesystem::path& dir);
// Writes DIR/study.json (creating DIR).
void write_study(const Study& study);
// std::invalid_argument naming DIR/study.json when it is absent or not a study.
Study read_study(const std::filesystem::path& dir);

std::filesystem::path session_maps_dir(const std::filesystem::path& dir, const std::string& name);
std::filesystem::path record_file(const std::filesystem::path& dir, const std::string& name);
// The record, or nullopt when there is none or it does not parse.
std::optional<nlohmann::ordered_json> read_record(const std::filesystem::path& dir, const std::string& name);
void write_json_durably(const std::filesystem::path& file, const nlohmann::ordered_json& json);

// This host's short name (for records and temporary names).
std::string host_name();
// The study's hold file.
std::filesystem::path hold_file(const std::filesystem::path& dir);

}  // namespace chromo::cli::study
