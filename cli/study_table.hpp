#pragma once
// The study table (docs/study.md "The table"): DIR/study.csv, one row per
// session and camera, gathered from the sessions' records.
//
// camera_rows() makes a session's rows when its maps are written: the
// parameters' statistics over the explained skin (flag 0) from each
// camera's maps.exr, and the flag counts and relit ΔE94 copied from its
// summary.json (so the table's values are the summary's).
//
// Thread rules: free functions.

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/maps/camera_results.hpp"
#include "study_folder.hpp"
#include "study_regions.hpp"

namespace chromo::cli::study {

// The parameters whose statistics the table holds (maps.exr channel names).
inline constexpr const char* kTableParameters[] = {"Cm", "Ch", "Bm", "Che"};
// Their statistics: mean and these quantiles (linear between order statistics: q(p) = v[h] interpolated at h = p·(n−1)).
inline constexpr std::pair<const char*, double> kTableQuantiles[] = {
    {"p05", 0.05}, {"p25", 0.25}, {"median", 0.5}, {"p75", 0.75}, {"p95", 0.95}};

// One JSON row per camera of a session estimated into maps_dir (the cameras
// as estimate_stored_session() returned them): {"camera", "state" (ok,
// failed), "error", "folder" (relative to maps_dir), "pixels", "explained",
// "flag_counts", "parameters": {"Cm": {"mean", "p05", ...}, ...},
// "relit_delta_e94": {"D65'": {"mean", "median", "p95"}, ...}}.
// With regions, "regions": {NAME: {"explained", "parameters"}} per camera
// whose mask exists ({NAME: {"missing": path}} otherwise); a mask that cannot
// be used throws std::invalid_argument naming it.
nlohmann::ordered_json camera_rows(const std::filesystem::path& maps_dir,
                                   const std::vector<maps::CameraEstimate>& cameras,
                                   const std::filesystem::path& session_folder = {},
                                   const std::vector<RegionSpec>& regions = {});

// The value at quantile p of `values` (sorted in place); NaN when empty.
double quantile_of_sorted(const std::vector<float>& sorted, double p);

// Writes DIR/study.csv from the records of the study's sessions (in the
// study's order; a session without a record is one row "pending"). Returns
// the number of rows.
std::size_t write_study_table(const Study& study, const std::string& estimator_version);

}  // namespace chromo::cli::study
