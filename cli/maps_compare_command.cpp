// chromo maps compare: two stored sessions of one subject, before and after
// (maps/session_difference.hpp): the after maps registered onto the before's,
// the difference of a channel with its noise (σ from both sessions' σ maps)
// and the pixels changed beyond the threshold; with --region, the region's
// statistics in both sessions. Prints JSON; --out DIR writes difference.exr
// (difference, sigma_difference, z, significant) and difference.png (z).
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <tuple>
#include <nlohmann/json.hpp>

#include "chromo/files/float_image.hpp"
#include "chromo/files/output_batch.hpp"
#include "chromo/maps/map_previews.hpp"
#include "chromo/maps/region_statistics.hpp"
#include "chromo/maps/session_difference.hpp"
#include "commands.hpp"
#include "maps_files.hpp"

namespace chromo::cli {

namespace fs = std::filesystem;

namespace {

struct MapsCompareOptions {
  fs::path before, after, out;
  std::string camera, region;
  maps::SessionDifferenceOptions difference;
};

nlohmann::ordered_json number(double v) { return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr); }

void run_maps_compare(const MapsCompareOptions& o) {
  const auto region = o.region.empty() ? std::nullopt : std::optional(maps::parse_pixel_rectangle(o.region, "--region"));
  const files::FloatImage before = read_maps_of(o.before, o.camera, "before");
  const files::FloatImage after = read_maps_of(o.after, o.camera, "after");
  const maps::SessionDifference d = maps::session_difference(before, after, o.difference);
  nlohmann::ordered_json out = {
      {"channel", o.difference.channel}, {"threshold_sigma", o.difference.threshold_sigma},
      {"width", d.width}, {"height", d.height},
      {"registration", {{"shift_x_px", d.registration.shift_x_px}, {"shift_y_px", d.registration.shift_y_px},
                        {"rotation_deg", d.registration.rotation_deg}, {"motion_px", d.motion_px},
                        {"residual_motion_px", d.registration.residual_motion_px}, {"warped", d.warped}}},
      {"compared_pixels", d.compared_pixels}, {"significant_pixels", d.significant_pixels},
      {"significant_share", d.compared_pixels ? static_cast<double>(d.significant_pixels) / static_cast<double>(d.compared_pixels) : 0.0}};
  if (region) {
    const files::FloatImage diff = maps::difference_maps(d);
    for (const auto& [name, image, channel] :
         {std::tuple{"before", &before, o.difference.channel}, std::tuple{"after", &d.after_registered, o.difference.channel},
          std::tuple{"difference", &diff, std::string("difference")}}) {
      const maps::RegionStatistics s = maps::region_statistics(*image, channel, *region);
      out["region"][name] = {{"pixels", s.pixels}, {"mean", number(s.mean)}, {"sd", number(s.sd)}, {"median", number(s.median)},
                             {"p5", number(s.p5)}, {"p95", number(s.p95)}};
    }
    const maps::RegionDifference change = maps::region_difference(d, *region, o.difference.threshold_sigma);
    out["region"]["change"] = {{"pixels", change.pixels},
                               {"median_difference", number(change.median_difference)},
                               {"sigma_of_median", number(change.sigma_of_median)},
                               {"z", number(change.z)},
                               {"significant", change.significant},
                               {"mean_difference", number(change.mean_difference)},
                               {"sigma_of_mean_from_sigma_maps", number(change.sigma_of_mean)}};
  }
  if (!o.out.empty()) {
    files::OutputBatch batch(o.out);
    files::write_exr(batch.temporary("difference.exr"), maps::difference_maps(d));
    std::vector<std::uint8_t> hide(d.z.size());
    for (std::size_t i = 0; i < hide.size(); ++i) hide[i] = std::isfinite(d.z[i]) ? maps::kPreviewShown : maps::kPreviewOutsideField;
    maps::write_map_png(batch.temporary("difference.png"), d.z, d.width, d.height, -2 * o.difference.threshold_sigma,
                        2 * o.difference.threshold_sigma, false, "z = diff / sigma\n" + o.difference.channel, hide);
    batch.commit();
    out["files"] = {(o.out / "difference.exr").string(), (o.out / "difference.png").string()};
  }
  std::cout << out.dump(2) << "\n";
}

}  // namespace

void add_maps_compare_command(CLI::App* maps_command, int& exit_status) {
  auto options = std::make_shared<MapsCompareOptions>();
  CLI::App* cmd = maps_command->add_subcommand(
      "compare", "two sessions of one subject: after registered onto before, the difference with its noise (JSON)");
  cmd->add_option("before", options->before, "session folder, chromo estimate --out folder or maps.exr")->required();
  cmd->add_option("after", options->after, "the same for the later session")->required();
  cmd->add_option("--channel", options->difference.channel, "channel compared (needs sigma_<channel>)")->capture_default_str();
  cmd->add_option("--threshold", options->difference.threshold_sigma, "|z| above it is a change")->capture_default_str();
  cmd->add_flag("!--no-registration", options->difference.register_sessions, "compare pixel by pixel, unregistered");
  cmd->add_option("--region", options->region, "x,y,width,height in map pixels: statistics in both sessions and the region's change against its sigma of the mean");
  cmd->add_option("--camera", options->camera, "camera of multi-camera sessions (results/<camera>/maps.exr)");
  cmd->add_option("--out", options->out, "folder for difference.exr and difference.png");
  cmd->callback([options, &exit_status] {
    exit_status = run_map_operation("maps compare", [&] { run_maps_compare(*options); });
  });
}

}  // namespace chromo::cli
