// chromo estimate: offline chromophore estimation from a measurement
// description (docs/formats/measurement.md) to parameter maps, previews and a
// summary. Everything is read and checked before anything is written; outputs
// are written under temporary names and renamed into place at the end.
#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/measurement_file.hpp"
#include "chromo/estimation/output_batch.hpp"
#include "chromo/estimation/spatial_flags.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"
#include "commands.hpp"
#include "chromo/estimation/image_files.hpp"

namespace chromo::cli {
namespace {

namespace fs = std::filesystem;
using estimation::FloatImage;
using estimation::ImageError;
using estimation::PixelFlag;
using estimation::write_category_png;
using estimation::write_exr;
using estimation::write_map_png;

struct EstimateOptions {
  std::string input;
  std::string out;
  std::string method = "fast";
  std::string model = "auto";
  std::string cache_dir;
  int threads = 0;
  bool neighbourhood_flags = false;
  bool order_pooling = true;
};

int run_estimate(const EstimateOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  auto seconds_since = [](auto t) { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count(); };
  if (fs::is_directory(options.input)) {
    std::cerr << "chromo estimate: " << options.input
              << " is a directory; estimating a stored session needs the daemon's session format, which this "
                 "build does not read yet. Give a MEASUREMENT.json (docs/formats/measurement.md).\n";
    return kExitBadInput;
  }
  estimation::MeasurementFile m;
  try {
    m = estimation::read_measurement_file(options.input);
  } catch (const estimation::MeasurementFileError& e) {
    std::cerr << "chromo estimate: " << e.what() << "\n";
    return kExitBadInput;
  }
  const double load_seconds = seconds_since(start);

  // Register every further image to images[0] on the first channel both use.
  auto t = std::chrono::steady_clock::now();
  nlohmann::ordered_json registration = nlohmann::ordered_json::array();
  try {
    for (const estimation::ImageRegistration& r : estimation::register_images(m))
      registration.push_back({{"image", r.image},
                              {"reference", r.reference},
                              {"channel", r.channel},
                              {"shift_x_px", r.result.shift_x_px},
                              {"shift_y_px", r.result.shift_y_px},
                              {"rotation_deg", r.result.rotation_deg},
                              {"correlation", r.result.correlation},
                              {"residual_motion_px", r.result.residual_motion_px}});
  } catch (const estimation::RegistrationError& e) {
    std::cerr << "chromo estimate: " << e.what() << "\n";
    return kExitBadInput;
  }
  const double registration_seconds = seconds_since(t);

  // Measurement set and the pixel-major measurement vector.
  estimation::MeasurementSet set = m.measurement_set();
  try {
    set.validate();
  } catch (const std::invalid_argument& e) {
    std::cerr << "chromo estimate: measurement set: " << e.what() << "\n";
    return kExitBadInput;
  }
  const std::size_t pixels = static_cast<std::size_t>(m.width) * m.height;
  const int channels = set.size();
  const std::vector<float> measured = m.pixel_major();

  t = std::chrono::steady_clock::now();
  bool rebuilt = false;
  std::shared_ptr<const estimation::ForwardTable> table;
  try {
    table = estimation::ForwardTable::load_or_build(
        set, {}, options.cache_dir.empty() ? estimation::ForwardTable::default_cache_dir() : fs::path(options.cache_dir),
        &rebuilt, options.threads);
  } catch (const std::exception& e) {
    std::cerr << "chromo estimate: building the table: " << e.what() << "\n";
    return kExitFailure;
  }
  const double table_seconds = seconds_since(t);

  estimation::EstimatorOptions eo;
  eo.method = options.method == "exhaustive" ? estimation::InverterMethod::kExhaustive
              : options.method == "2d"       ? estimation::InverterMethod::k2d
                                             : estimation::InverterMethod::kFast;
  eo.model = options.model == "2d" ? estimation::ModelChoice::k2d
             : options.model == "4d" ? estimation::ModelChoice::k4d
                                     : estimation::ModelChoice::kAuto;
  eo.threads = options.threads;
  eo.cache_dir = options.cache_dir;  // the fast method's inverse table next to the forward table
  t = std::chrono::steady_clock::now();
  const estimation::Estimator estimator(table, set, eo);
  const double inverter_setup_seconds = seconds_since(t);
  std::vector<estimation::PixelEstimate> out(pixels);
  estimation::EstimateSummary summary = estimator.estimate(measured, out);
  estimation::NeighbourhoodSummary neighbourhood;
  double neighbourhood_seconds = 0;
  if (options.neighbourhood_flags || options.order_pooling) {
    estimation::NeighbourhoodOptions no;
    no.flags = options.neighbourhood_flags;
    no.pool_order = options.order_pooling;
    t = std::chrono::steady_clock::now();
    neighbourhood = estimation::refine_with_neighbourhood(estimator, measured, m.width, m.height, out, summary, no);
    neighbourhood_seconds = seconds_since(t);
  }

  // Maps.
  FloatImage maps;
  maps.width = m.width, maps.height = m.height;
  maps.channel_names = {"Cm", "Ch", "Bm", "Che", "residual", "order", "flags"};
  maps.channels.assign(7, std::vector<float>(pixels));
  std::vector<std::uint8_t> hide(pixels);
  std::vector<double> residuals;
  for (std::size_t i = 0; i < pixels; ++i) {
    const auto& e = out[i];
    const float values[7] = {float(e.parameters.cm), float(e.parameters.ch), float(e.parameters.bm),
                             float(e.parameters.che), e.residual, float(e.order), float(static_cast<int>(e.flag))};
    for (int c = 0; c < 7; ++c) maps.channels[c][i] = values[c];
    hide[i] = e.flag != PixelFlag::kExplained && e.flag != PixelFlag::kSpecular;
    if (e.order > 0) residuals.push_back(e.residual);
  }
  std::sort(residuals.begin(), residuals.end());
  auto quantile = [&](double q) {
    return residuals.empty() ? 0.0 : residuals[std::min(residuals.size() - 1, std::size_t(q * (residuals.size() - 1) + 0.5))];
  };
  double residual_sum = 0;
  for (double r : residuals) residual_sum += r;

  nlohmann::ordered_json s;
  s["input"] = options.input;
  s["method"] = options.method;
  s["model"] = options.model;
  s["width"] = m.width;
  s["height"] = m.height;
  s["channels"] = nlohmann::json::array();
  for (const auto& c : set.channels) s["channels"].push_back(c.name);
  s["table"] = {{"key", fmt::format("{:016x}", table->key())},
                {"nodes", table->grid().node_count()},
                {"rebuilt", rebuilt}};
  s["registration"] = registration;
  s["timings_s"] = {{"load", load_seconds},          {"registration", registration_seconds},
                    {"table", table_seconds},        {"inverter_setup", inverter_setup_seconds},
                    {"estimate", summary.seconds},   {"neighbourhood", neighbourhood_seconds}};
  s["neighbourhood"] = {{"flags", options.neighbourhood_flags},
                        {"order_pooling", options.order_pooling},
                        {"flagged_touching_flagged_regions", neighbourhood.flagged_touching},
                        {"flagged_enclosed", neighbourhood.flagged_holes},
                        {"order_changed_to_4", neighbourhood.order_to_4},
                        {"order_changed_to_2", neighbourhood.order_to_2}};
  s["pixels"] = pixels;
  s["pixels_per_second"] = summary.seconds > 0 ? pixels / summary.seconds : 0.0;
  s["residual"] = {{"unit", "albedo RMS over channels"},
                   {"mean", residuals.empty() ? 0.0 : residual_sum / residuals.size()},
                   {"median", quantile(0.5)},
                   {"p95", quantile(0.95)},
                   {"max", residuals.empty() ? 0.0 : residuals.back()}};
  s["order_counts"] = {{"2", summary.order2}, {"4", summary.order4}};
  nlohmann::ordered_json flags;
  for (int f = 0; f < estimation::kPixelFlagCount; ++f)
    flags[std::string(estimation::pixel_flag_name(static_cast<PixelFlag>(f)))] = summary.flag_counts[f];
  s["flag_counts"] = flags;

  // Write everything under temporary names, then rename.
  try {
    estimation::OutputBatch files(options.out);
    write_exr(files.temporary("maps.exr"), maps);
    struct Preview {
      const char* file;
      int channel;
      double low, high;
      bool log;
    };
    for (const Preview& p : {Preview{"cm.png", 0, estimation::kCmRange.min, estimation::kCmRange.max, true},
                             Preview{"ch.png", 1, estimation::kChRange.min, estimation::kChRange.max, true},
                             Preview{"bm.png", 2, 0.0, 1.0, false}, Preview{"che.png", 3, 0.0, 0.1, false},
                             Preview{"residual.png", 4, 0.0, std::max(quantile(0.99), 1e-6), false}})
      write_map_png(files.temporary(p.file), maps.channels[p.channel], m.width, m.height, p.low, p.high, p.log,
                    maps.channel_names[p.channel], hide);
    std::vector<std::string> flag_names;
    for (int f = 0; f < estimation::kPixelFlagCount; ++f)
      flag_names.emplace_back(estimation::pixel_flag_name(static_cast<PixelFlag>(f)));
    write_category_png(files.temporary("flags.png"), maps.channels[6], m.width, m.height, flag_names);
    write_category_png(files.temporary("order.png"), maps.channels[5], m.width, m.height, {"none", "", "2D", "", "4D"});
    s["timings_s"]["total"] = seconds_since(start);
    files.write_text("summary.json", s.dump(2) + "\n");
    files.commit();
  } catch (const std::exception& e) {
    std::cerr << "chromo estimate: writing " << options.out << ": " << e.what() << "\n";
    return kExitFailure;
  }
  fmt::print("{}×{} pixels, {} channels, method {} model {}: {:.3f} s ({:.0f} pixels/s); {} explained, {} flagged\n",
             m.width, m.height, channels, options.method, options.model, summary.seconds,
             summary.seconds > 0 ? pixels / summary.seconds : 0.0, summary.flag_counts[0],
             pixels - summary.flag_counts[0]);
  return kExitOk;
}

}  // namespace

void add_estimate_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<EstimateOptions>();
  CLI::App* cmd = app.add_subcommand("estimate", "Estimate chromophore maps from a measurement (MEASUREMENT.json)");
  cmd->add_option("measurement", options->input, "MEASUREMENT.json (docs/formats/measurement.md)")->required();
  cmd->add_option("--out", options->out, "output directory (maps.exr, previews, summary.json)")->required();
  cmd->add_option("--method", options->method, "inverter")
      ->check(CLI::IsMember({"exhaustive", "fast", "2d"}))
      ->capture_default_str();
  cmd->add_option("--model", options->model, "model order: auto (χ² likelihood-ratio test, pooled over 7×7 windows unless --no-order-pooling), 2d or 4d")
      ->check(CLI::IsMember({"auto", "2d", "4d"}))
      ->capture_default_str();
  cmd->add_flag("--neighbourhood-flags", options->neighbourhood_flags,
                "also flag pixels from their neighbourhood (code 7: weak rims of flagged regions, weak highlights; "
                "assumes skin varies slowly over ~20 px, see docs/estimation.md)");
  cmd->add_flag("!--no-order-pooling", options->order_pooling,
                "with --model auto, decide the order per pixel only (default: the likelihood-ratio statistic pooled "
                "over 7×7 windows)");
  cmd->add_option("--cache-dir", options->cache_dir, "table cache (default $CHROMO_CACHE_DIR or ~/.cache/chromosphere)");
  cmd->add_option("--threads", options->threads, "threads (0 = all cores)")->capture_default_str();
  cmd->callback([options, &exit_status] { exit_status = run_estimate(*options); });
}

}  // namespace chromo::cli
