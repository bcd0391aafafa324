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
#include "chromo/estimation/spatial_flags.hpp"
#include "chromo/estimation/registration.hpp"
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
using estimation::read_exr;
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

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct LoadedImage {
  std::string name;
  FloatImage pixels;
  std::vector<std::string> channels;  // camera channels used: R, G, B
  spectral::Spectrum illuminant;
  estimation::ChannelNoise noise;
};

struct Measurement {
  spectral::CameraSensitivity camera;
  std::vector<LoadedImage> images;
  int width = 0, height = 0;
};

estimation::ChannelNoise parse_noise(const nlohmann::json& j, estimation::ChannelNoise base, const std::string& where) {
  if (j.is_null()) return base;
  if (!j.is_object()) throw InputError(where + ": 'noise' must be an object");
  for (const auto& [key, value] : j.items()) {
    if (!value.is_number()) throw InputError(where + ": noise." + key + " must be a number");
    if (key == "read_sigma") base.read_sigma = value.get<double>();
    else if (key == "shot_coefficient") base.shot_coefficient = value.get<double>();
    else if (key == "saturation_albedo") base.saturation_albedo = value.get<double>();
    else throw InputError(where + ": unknown noise key '" + key + "' (read_sigma, shot_coefficient, saturation_albedo)");
  }
  return base;
}

Measurement load_measurement(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw InputError(file.string() + ": cannot open");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(file.string() + ": not valid JSON: " + e.what());
  }
  const fs::path base = file.parent_path();
  auto resolve = [&](const std::string& p) { return fs::path(p).is_absolute() ? fs::path(p) : base / p; };
  auto need_string = [&](const nlohmann::json& o, const char* key, const std::string& where) {
    if (!o.contains(key) || !o[key].is_string()) throw InputError(where + ": missing string '" + key + "'");
    return o[key].get<std::string>();
  };
  Measurement m;
  const std::string camera = need_string(j, "camera", file.string());
  try {
    m.camera = camera.rfind("builtin:", 0) == 0 ? spectral::builtin_camera(camera.substr(8))
                                                : spectral::read_camera_sensitivity(resolve(camera));
  } catch (const spectral::DataError& e) {
    throw InputError(std::string("camera: ") + e.what());
  }
  const estimation::ChannelNoise default_noise = parse_noise(j.value("noise", nlohmann::json()), {}, file.string());
  if (!j.contains("images") || !j["images"].is_array() || j["images"].empty())
    throw InputError(file.string() + ": 'images' must be a non-empty array");
  for (std::size_t k = 0; k < j["images"].size(); ++k) {
    const nlohmann::json& o = j["images"][k];
    const std::string where = fmt::format("{}: images[{}]", file.string(), k);
    if (!o.is_object()) throw InputError(where + " must be an object");
    LoadedImage image;
    image.name = o.value("name", fmt::format("image{}", k));
    try {
      image.pixels = read_exr(resolve(need_string(o, "file", where)));
      image.illuminant = spectral::read_spectrum_file(resolve(need_string(o, "illuminant", where)));
    } catch (const ImageError& e) {
      throw InputError(where + ": " + e.what());
    } catch (const spectral::DataError& e) {
      throw InputError(where + ": illuminant: " + e.what());
    }
    if (!o.contains("channels") || !o["channels"].is_array() || o["channels"].empty())
      throw InputError(where + ": 'channels' must be a non-empty array of \"R\", \"G\", \"B\"");
    for (const auto& c : o["channels"]) {
      if (!c.is_string() || (c != "R" && c != "G" && c != "B"))
        throw InputError(where + ": channel " + c.dump() + " is not \"R\", \"G\" or \"B\"");
      try {
        image.pixels.channel(c.get<std::string>());
      } catch (const ImageError& e) {
        throw InputError(where + ": " + e.what());
      }
      image.channels.push_back(c.get<std::string>());
    }
    image.noise = parse_noise(o.value("noise", nlohmann::json()), default_noise, where);
    if (k == 0) m.width = image.pixels.width, m.height = image.pixels.height;
    if (image.pixels.width != m.width || image.pixels.height != m.height)
      throw InputError(fmt::format("{}: {}×{} pixels, but images[0] has {}×{}", where, image.pixels.width,
                                   image.pixels.height, m.width, m.height));
    m.images.push_back(std::move(image));
  }
  return m;
}

int channel_index(const std::string& name) { return name == "R" ? 0 : name == "G" ? 1 : 2; }

struct OutputFiles {
  fs::path dir;
  std::vector<std::pair<fs::path, fs::path>> pending;  // temporary → final
  fs::path temporary(const std::string& name) {
    const fs::path t = dir / (".tmp-" + name), f = dir / name;
    pending.emplace_back(t, f);
    return t;
  }
  void commit() {
    for (const auto& [t, f] : pending) fs::rename(t, f);
    pending.clear();
  }
  ~OutputFiles() {
    std::error_code ec;
    for (const auto& [t, f] : pending) fs::remove(t, ec);
  }
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
  Measurement m;
  try {
    m = load_measurement(options.input);
  } catch (const InputError& e) {
    std::cerr << "chromo estimate: " << e.what() << "\n";
    return kExitBadInput;
  }
  const double load_seconds = seconds_since(start);

  // Register every further image to images[0] on the first channel both use.
  auto t = std::chrono::steady_clock::now();
  nlohmann::ordered_json registration = nlohmann::ordered_json::array();
  for (std::size_t k = 1; k < m.images.size(); ++k) {
    LoadedImage& image = m.images[k];
    std::string shared;
    for (const auto& c : image.channels)
      if (std::find(m.images[0].channels.begin(), m.images[0].channels.end(), c) != m.images[0].channels.end()) {
        shared = c;
        break;
      }
    if (shared.empty()) shared = image.channels.front();
    try {
      const estimation::RegistrationResult r = estimation::register_channel(
          m.images[0].pixels.channel(shared), image.pixels.channel(shared), m.width, m.height);
      for (auto& channel : image.pixels.channels) channel = estimation::warp_channel(channel, m.width, m.height, r);
      registration.push_back({{"image", image.name},
                              {"reference", m.images[0].name},
                              {"channel", shared},
                              {"shift_x_px", r.shift_x_px},
                              {"shift_y_px", r.shift_y_px},
                              {"rotation_deg", r.rotation_deg},
                              {"correlation", r.correlation},
                              {"residual_motion_px", r.residual_motion_px}});
    } catch (const estimation::RegistrationError& e) {
      std::cerr << "chromo estimate: registering " << image.name << " to " << m.images[0].name << ": " << e.what()
                << "\n";
      return kExitBadInput;
    }
  }
  const double registration_seconds = seconds_since(t);

  // Measurement set and the pixel-major measurement vector.
  estimation::MeasurementSet set{m.camera, {}};
  std::vector<const std::vector<float>*> planes;
  for (const LoadedImage& image : m.images)
    for (const auto& c : image.channels) {
      set.channels.push_back({image.name + "." + c, image.illuminant, channel_index(c), image.noise});
      planes.push_back(&image.pixels.channel(c));
    }
  try {
    set.validate();
  } catch (const std::invalid_argument& e) {
    std::cerr << "chromo estimate: measurement set: " << e.what() << "\n";
    return kExitBadInput;
  }
  const std::size_t pixels = static_cast<std::size_t>(m.width) * m.height;
  const int channels = set.size();
  std::vector<float> measured(pixels * channels);
  for (std::size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < channels; ++c) measured[i * channels + c] = (*planes[c])[i];

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
    fs::create_directories(options.out);
    OutputFiles files{options.out, {}};
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
    std::ofstream(files.temporary("summary.json")) << s.dump(2) << "\n";
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
