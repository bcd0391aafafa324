// chromo flush: scale parameters inside a feathered mask and relight before
// and after: the paper's simulated flushing (docs/maps.md).
#include <fmt/format.h>

#include <iostream>
#include <sstream>

#include "chromo/maps/map_operations.hpp"
#include "commands.hpp"

namespace chromo::cli {
namespace {

std::vector<double> numbers(const std::string& text, const std::string& option) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0') throw std::invalid_argument(option + ": \"" + item + "\" is not a number");
    out.push_back(v);
  }
  return out;
}

struct FlushCommandOptions {
  maps::FlushOptions options;
  std::string scale, ellipse, polygon;
};

void parse(FlushCommandOptions& c) {
  std::stringstream in(c.scale);
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) throw std::invalid_argument("scale: \"" + item + "\" is not name=factor");
    const std::string name = item.substr(0, eq);
    const double v = numbers(item.substr(eq + 1), "scale." + name).at(0);
    if (name == "cm") c.options.scale.cm = v;
    else if (name == "ch") c.options.scale.ch = v;
    else if (name == "bm") c.options.scale.bm = v;
    else if (name == "che") c.options.scale.che = v;
    else throw std::invalid_argument("scale: unknown parameter \"" + name + "\" (cm, ch, bm, che)");
  }
  if (!c.ellipse.empty()) {
    const auto v = numbers(c.ellipse, "ellipse");
    if (v.size() != 4 && v.size() != 5) throw std::invalid_argument("ellipse: give cx,cy,rx,ry[,angle_deg] in pixels");
    c.options.ellipse = maps::EllipseShape{v[0], v[1], v[2], v[3], v.size() == 5 ? v[4] : 0.0};
  }
  if (!c.polygon.empty()) {
    const auto v = numbers(c.polygon, "polygon");
    if (v.size() < 6 || v.size() % 2) throw std::invalid_argument("polygon: give x1,y1,x2,y2,x3,y3,... (≥ 3 vertices)");
    maps::PolygonShape p;
    for (std::size_t k = 0; k < v.size(); k += 2) p.vertices_px.emplace_back(v[k], v[k + 1]);
    c.options.polygon = p;
  }
}

}  // namespace

void add_flush_command(CLI::App& app, int& exit_status) {
  auto c = std::make_shared<FlushCommandOptions>();
  CLI::App* cmd = app.add_subcommand("flush", "Scale parameters inside a feathered mask and relight (simulated flushing)");
  cmd->add_option("maps", c->options.maps, "maps.exr from chromo estimate")->required();
  cmd->add_option("--scale", c->scale, "factors, e.g. ch=1.6,che=2.0 (cm, ch, bm, che)")->required();
  auto* ellipse = cmd->add_option("--ellipse", c->ellipse, "cx,cy,rx,ry[,angle_deg] in pixels");
  auto* polygon = cmd->add_option("--polygon", c->polygon, "x1,y1,x2,y2,x3,y3,... in pixels");
  auto* mask = cmd->add_option("--mask", c->options.mask, "mask image (8/16-bit grey, maps' size; > 50% = inside)");
  ellipse->excludes(polygon)->excludes(mask);
  polygon->excludes(mask);
  cmd->add_option("--feather", c->options.feather_px, "soft edge: ramp width each side of the outline, pixels")
      ->capture_default_str();
  cmd->add_option("--illuminant", c->options.illuminant, "as for chromo relight")->capture_default_str();
  cmd->add_option("--out", c->options.out, "output directory")->required();
  cmd->add_option("--threads", c->options.threads, "threads (0 = all cores)");
  cmd->callback([c, &exit_status] {
    exit_status = run_map_operation("flush", [&] {
      parse(*c);
      const auto s = maps::flush_to_files(c->options);
      fmt::print("{} pixels edited; {} values clamped to MODEL.md's ranges ({:.2f}% of edited values: Cm {}, Ch {}, "
                 "βm {}, Che {})\n",
                 s.edit.pixels_touched, s.edit.values_clamped, 100 * s.edit.clamped_share, s.edit.clamped_cm,
                 s.edit.clamped_ch, s.edit.clamped_bm, s.edit.clamped_che);
      fmt::print("colour change under {} inside the mask: ΔE94 mean {:.2f}, p95 {:.2f}, max {:.2f} → {}\n",
                 s.illuminant, s.change_delta_e94.mean, s.change_delta_e94.p95, s.change_delta_e94.max,
                 c->options.out.string());
    });
  });
}

}  // namespace chromo::cli
