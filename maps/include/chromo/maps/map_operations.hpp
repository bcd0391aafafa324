#pragma once
// What the estimated maps are for (issue 7), as whole operations shared by
// the `chromo` commands and the daemon's Maps service (docs/maps.md):
//   relight_to_files       relit albedo under any illuminant (+ a panel against a photograph)
//   flush_to_files         scale parameters inside a feathered mask, relight before/after
//   import_maps_to_files   external melanin/hemoglobin maps → 2D mapping, augmented, 4D search (Table 2)
//   export_profiles_to_files  radial profile tables for renderers (+ index map)
//
// Every operation reads and checks all of its inputs first and throws
// std::invalid_argument whose message starts with the name of the offending
// field ("maps: ...", "illuminant: ...", "ellipse: ..."), the same names the
// command-line options and the API's request fields use. Only then does it
// compute and write its files through an files::OutputBatch (temporary names,
// fsync, rename): on any failure nothing is left behind in `out`. Files
// already in `out` with other names are left alone; files of the same name
// are replaced only at the final rename.
//
// Summaries carry the numbers and `json`, the text also written as the
// operation's JSON file. Each call is synchronous and runs on `threads`
// threads (0 = all cores). Thread-safe (no shared state).

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "chromo/maps/external_maps.hpp"
#include "chromo/maps/parameter_edit.hpp"
#include "chromo/maps/profile_table.hpp"
#include "chromo/maps/reconstruction.hpp"

namespace chromo::maps {

struct RelightOptions {
  std::filesystem::path maps;        // maps.exr (chromo estimate)
  std::string illuminant = "D65";    // relight.hpp's resolve_illuminant
  std::filesystem::path out;
  std::filesystem::path photograph;  // optional: camera RGB albedo (R, G, B) under the illuminant, maps' size
  std::string camera = "builtin:nikon_d5100";  // the photograph's camera: builtin:<name> or a CSV
  double heat_map_max = 0;           // ΔE94 at the top of the colour bar; 0 = the p95 clamped to [1, 5]
  int threads = 0;
  // Add the maps' posterior discrepancy where they carry one (the relit layer
  // "model + discrepancy", discrepancy_layer.hpp); false: the model alone.
  bool discrepancy_layer = true;
};
struct RelightSummary {
  std::string illuminant;
  int width = 0, height = 0;
  std::size_t relit_pixels = 0;
  bool compared = false;             // a photograph was given
  bool discrepancy_layer = false;    // the maps' discrepancy layer was added
  DeltaEStats photo_delta_e94;
  std::vector<std::filesystem::path> files;
  std::string json;
};
// Files: relit.exr (linear sRGB R, G, B + valid), relit.png, relight.json;
// with a photograph also panel.png (photograph | reconstruction | ΔE94) and
// delta_e94.exr.
RelightSummary relight_to_files(const RelightOptions& options);

struct FlushOptions {
  std::filesystem::path maps;
  ParameterScale scale;                 // e.g. ch 1.6, che 2.0
  std::optional<EllipseShape> ellipse;  // exactly one of ellipse, polygon, mask
  std::optional<PolygonShape> polygon;
  std::filesystem::path mask;
  double feather_px = 0;
  std::string illuminant = "D65";
  std::filesystem::path out;
  int threads = 0;
};
struct FlushSummary {
  EditReport edit;
  std::string illuminant;
  DeltaEStats change_delta_e94;  // before → after, over the pixels the edit touched
  std::vector<std::filesystem::path> files;
  std::string json;
};
// Files: maps.exr (the input's channels, Cm/Ch/Bm/Che edited), mask.png,
// before.png, after.png, panel.png (before | after | ΔE94 of the change), flush.json.
FlushSummary flush_to_files(const FlushOptions& options);

struct ImportMapsOptions {
  std::filesystem::path melanin, hemoglobin;
  std::filesystem::path measurement;  // MEASUREMENT.json, or a folder holding one
  std::filesystem::path statistics_mask;  // optional grey image: > 50% = in the statistics
  std::filesystem::path out;
  ImportOptions import;
};
struct ImportMapsSummary {
  ImportResult result;
  std::vector<std::filesystem::path> files;
  std::string json;
};
// Files: maps_2d.exr, maps_augmented.exr, maps_4d.exr, comparison.json,
// panel.png (photograph and the three reconstructions; ΔE94 maps below),
// mapping.png (the fitted monotone mappings).
ImportMapsSummary import_maps_to_files(const ImportMapsOptions& options);

struct ExportProfilesOptions {
  std::string illuminant = "D65";
  std::filesystem::path out;
  std::filesystem::path maps;  // optional: also index.exr
  ProfileTableAxes axes = ProfileTableAxes::Default();
  int threads = 0;
  files::Progress progress;    // optional (profile_table.hpp)
};
struct ExportProfilesSummary {
  std::size_t entries = 0, radii = 0, unmapped_pixels = 0;
  double worst_plane_integral_error = 0;
  std::vector<std::filesystem::path> files;
};
ExportProfilesSummary export_profiles_to_files(const ExportProfilesOptions& options);

}  // namespace chromo::maps
