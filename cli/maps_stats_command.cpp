// chromo maps stats: statistics of map channels inside a rectangle of map
// pixels, computed from a stored session's maps.exr at full resolution: the
// numbers the web view's map explorer shows for a drawn region and
// MapsService.GetRegionStatistics answers (maps/region_statistics.hpp).
// Reads only; prints CSV (or JSON with --json) on stdout.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "chromo/files/float_image.hpp"
#include "chromo/maps/region_statistics.hpp"
#include "commands.hpp"
#include "maps_files.hpp"

namespace chromo::cli {

namespace fs = std::filesystem;

namespace {

struct MapsStatsOptions {
  fs::path input;
  std::string camera;
  std::string region;
  std::vector<std::string> channels{"Cm", "Ch", "Bm", "Che"};
  bool json = false;
};

nlohmann::ordered_json statistics_json(const maps::RegionStatistics& s) {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr); };
  return {{"channel", s.channel}, {"unit", s.unit},
          {"region", {{"x", s.region.x}, {"y", s.region.y}, {"width", s.region.width}, {"height", s.region.height}}},
          {"region_pixels", s.region_pixels}, {"pixels", s.pixels}, {"flagged_pixels", s.flagged_pixels},
          {"outside_field_pixels", s.outside_field_pixels}, {"mean", number(s.mean)}, {"sd", number(s.sd)},
          {"min", number(s.min)}, {"p1", number(s.p1)}, {"p5", number(s.p5)}, {"p25", number(s.p25)},
          {"median", number(s.median)}, {"p75", number(s.p75)}, {"p95", number(s.p95)}, {"p99", number(s.p99)},
          {"max", number(s.max)}};
}

void run_maps_stats(const MapsStatsOptions& o) {
  const maps::PixelRectangle region = maps::parse_pixel_rectangle(o.region, "--region");
  const fs::path file = maps_file_of(o.input, o.camera);
  const files::FloatImage image = read_maps_of(file, "", file.string());
  std::vector<maps::RegionStatistics> rows;
  for (const std::string& channel : o.channels) {
    try {
      rows.push_back(maps::region_statistics(image, channel, region));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(file.string() + ": --" + e.what());
    }
  }
  if (!o.json) {
    std::cout << maps::region_statistics_csv(rows);
    return;
  }
  nlohmann::ordered_json out = {{"maps_file", file.string()}, {"width", image.width}, {"height", image.height},
                                {"statistics", nlohmann::ordered_json::array()}};
  for (const auto& s : rows) out["statistics"].push_back(statistics_json(s));
  std::cout << out.dump(2) << "\n";
}

}  // namespace

void add_maps_command(CLI::App& app, int& exit_status) {
  CLI::App* maps_command = app.add_subcommand("maps", "read a stored session's maps");
  maps_command->require_subcommand(1);
  auto options = std::make_shared<MapsStatsOptions>();
  CLI::App* cmd = maps_command->add_subcommand(
      "stats", "statistics of map channels inside a rectangle of map pixels, from maps.exr (as the web view shows them)");
  cmd->add_option("session", options->input, "session folder, a chromo estimate --out folder, or a maps.exr")->required();
  cmd->add_option("--region", options->region, "x,y,width,height in map pixels (maps.exr's grid)")->required();
  cmd->add_option("--channel", options->channels, "channels (repeatable; default Cm Ch Bm Che)");
  cmd->add_option("--camera", options->camera, "camera of a multi-camera session (results/<camera>/maps.exr)");
  cmd->add_flag("--json", options->json, "JSON instead of CSV");
  cmd->callback([options, &exit_status] { exit_status = run_map_operation("maps stats", [&] { run_maps_stats(*options); }); });
  add_maps_compare_command(maps_command, exit_status);
}

}  // namespace chromo::cli
