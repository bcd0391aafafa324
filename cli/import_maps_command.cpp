// chromo import-maps: another device's relative melanin and hemoglobin maps
// brought into this model (2D mapping, augmented) and compared with the 4D
// search, as the paper's Table 2 (docs/maps.md). Also writes the synthetic
// test data set (make-maps-test-data).
#include <fmt/format.h>

#include "chromo/maps/map_operations.hpp"
#include "chromo/simulators/scene/external_maps_scene.hpp"
#include "chromo/maps/region_statistics.hpp"
#include "commands.hpp"

namespace chromo::cli {

void add_import_maps_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<maps::ImportMapsOptions>();
  auto method = std::make_shared<std::string>("fast");
  CLI::App* cmd = app.add_subcommand(
      "import-maps", "Map external melanin/hemoglobin maps to (Cm, Ch), augment, compare with the 4D search");
  cmd->add_option("--melanin", options->melanin, "relative melanin map (8/16-bit grey PNG/TIFF or EXR)")->required();
  cmd->add_option("--hemoglobin", options->hemoglobin, "relative hemoglobin map, same size")->required();
  cmd->add_option("--albedo", options->measurement, "MEASUREMENT.json (or its folder) of the same subject")->required();
  cmd->add_option("--out", options->out, "output directory")->required();
  cmd->add_option("--stats-mask", options->statistics_mask, "grey image: only pixels > 50% enter the statistics");
  cmd->add_option("--prior-sigma", options->import.prior_sigma_log10,
                  "augmented fit: σ of the (Cm, Ch) prior in log10")->capture_default_str();
  cmd->add_option("--search", *method, "4D search: fast or exhaustive")
      ->check(CLI::IsMember({"fast", "exhaustive"}))->capture_default_str();
  cmd->add_option("--cache-dir", options->import.cache_dir, "forward-table cache");
  cmd->add_option("--threads", options->import.threads, "threads (0 = all cores)");
  cmd->callback([options, method, &exit_status] {
    options->import.search_4d = *estimation::parse_method_name(*method);  // checked by IsMember above
    exit_status = run_map_operation("import-maps", [&] {
      const auto s = maps::import_maps_to_files(*options);
      const auto& r = s.result;
      fmt::print("mean ΔE94 against {} ({} pixels):\n", r.photograph_name, r.search_4d.stats.pixels);
      fmt::print("  {:<12} {:>8} {:>8} {:>8}\n", "method", "mean", "median", "p95");
      for (const auto* m : {&r.mapped_2d, &r.augmented, &r.search_4d})
        fmt::print("  {:<12} {:>8.4f} {:>8.4f} {:>8.4f}\n", m->name, m->stats.mean, m->stats.median, m->stats.p95);
      fmt::print("mappings: melanin → Cm {}, hemoglobin → Ch {} ({} / {} knots) → {}\n",
                 r.cm_mapping.increasing ? "increasing" : "decreasing",
                 r.ch_mapping.increasing ? "increasing" : "decreasing", r.cm_mapping.input.size(),
                 r.ch_mapping.input.size(), options->out.string());
    });
  });

  auto scene = std::make_shared<simulators::ExternalMapsSceneOptions>();
  auto out = std::make_shared<std::string>();
  CLI::App* data = app.add_subcommand(
      "make-maps-test-data", "Synthetic test data for import-maps/relight/flush (virtual-lab skin scene, docs/maps.md)");
  data->add_option("--out", *out, "output directory")->required();
  data->add_option("--width", scene->width)->capture_default_str();
  data->add_option("--height", scene->height)->capture_default_str();
  data->add_option("--seed", scene->seed)->capture_default_str();
  data->add_option("--camera-noise", scene->camera_noise_scale, "camera noise scale (0 = noise-free)")->capture_default_str();
  data->add_option("--map-noise", scene->map_noise_fraction, "imported maps' noise, fraction of full scale")
      ->capture_default_str();
  data->add_option("--noise-seed", scene->noise_seed, "another draw of the camera noise (a second session; 0: from --seed)");
  data->add_option("--ch-factor", scene->ch_factor, "Ch multiplied by this inside --ch-change (a changed subject)");
  auto ch_change = std::make_shared<std::string>();
  data->add_option("--ch-change", *ch_change, "x,y,width,height of the scene where --ch-factor applies");
  data->callback([scene, out, ch_change, &exit_status] {
    exit_status = run_map_operation("make-maps-test-data", [&] {
      if (!ch_change->empty()) {
        const maps::PixelRectangle r = maps::parse_pixel_rectangle(*ch_change, "--ch-change");
        scene->ch_change_x = r.x, scene->ch_change_y = r.y, scene->ch_change_width = r.width, scene->ch_change_height = r.height;
      }
      simulators::write_external_maps_scene(*out, *scene);
      fmt::print("{}x{} test scene → {} (MEASUREMENT.json, melanin.png, hemoglobin.png, skin_mask.png, truth.exr)\n", scene->width,
                 scene->height, *out);
    });
  });
}

}  // namespace chromo::cli
