#include "chromo/maps/map_operations.hpp"

#include <opencv2/imgproc.hpp>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "chromo/files/float_image.hpp"
#include "chromo/maps/map_panels.hpp"
#include "chromo/files/output_batch.hpp"
#include "chromo/maps/radial_profile.hpp"
#include "chromo/maps/relight.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "chromo/spectral/srgb.hpp"
#include "chromo/spectral/table.hpp"
#include "delta_e_json.hpp"

namespace chromo::maps {
namespace fs = std::filesystem;
using nlohmann::ordered_json;

namespace {

std::invalid_argument field_error(const std::string& field, const std::string& message) {
  return std::invalid_argument(field + ": " + message);
}

void check_out(const fs::path& out) {
  if (out.empty()) throw field_error("out", "required");
  if (fs::exists(out) && !fs::is_directory(out)) throw field_error("out", out.string() + " exists and is not a directory");
}

// The maps file with every channel (edits keep what they do not change).
struct LoadedMaps {
  files::FloatImage image;
  ParameterMaps maps;
};
LoadedMaps load_maps(const fs::path& path) {
  if (path.empty()) throw field_error("maps", "required");
  if (!fs::exists(path)) throw field_error("maps", path.string() + ": no such file");
  try {
    LoadedMaps loaded{files::read_exr(path), read_parameter_maps(path)};
    if (loaded.maps.width <= 0 || loaded.maps.height <= 0) throw field_error("maps", path.string() + ": empty image");
    return loaded;
  } catch (const std::runtime_error& e) {  // files::ImageError and read_parameter_maps' errors
    throw field_error("maps", e.what());
  }
}

NamedSpectrum illuminant_field(const std::string& text) {
  try {
    return resolve_illuminant(text);
  } catch (const std::invalid_argument& e) {
    throw field_error("illuminant", e.what());
  }
}

std::string number(double v, int digits = 2) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, v);
  return buffer;
}

std::string stats_caption(const DeltaEStats& s) {
  return "mean " + number(s.mean) + "  median " + number(s.median) + "  p95 " + number(s.p95);
}

// Automatic colour-bar top: the p95, between 1 and 5 ΔE94 (pixels no
// parameters explain would otherwise stretch the bar and hide skin errors).
double heat_max(double requested, const DeltaEStats& s) {
  return requested > 0 ? requested : std::clamp(s.p95, 1.0, 5.0);
}

// Camera RGB → XYZ (Ohta-chart fit) → linear sRGB, for showing photographs and
// camera reconstructions the same way.
std::vector<float> camera_to_linear_srgb(const std::vector<float>& camera_rgb, const spectral::CameraSensitivity& camera,
                                         const spectral::Spectrum& illuminant) {
  const Eigen::Matrix3d to_xyz = camera_to_xyz_matrix(camera, illuminant);
  const spectral::Xyz white = spectral::white_point(illuminant);
  std::vector<float> out(camera_rgb.size());
  for (std::size_t i = 0; i + 2 < camera_rgb.size(); i += 3) {
    const Eigen::Vector3d x = to_xyz * Eigen::Vector3d(camera_rgb[i], camera_rgb[i + 1], camera_rgb[i + 2]);
    const spectral::Rgb rgb = spectral::linear_srgb_from_xyz({x[0], x[1], x[2]}, white);
    out[i] = static_cast<float>(rgb.r), out[i + 1] = static_cast<float>(rgb.g), out[i + 2] = static_cast<float>(rgb.b);
  }
  return out;
}

files::FloatImage rgb_image(const std::vector<float>& rgb, int width, int height) {
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  files::FloatImage image{width, height, {"R", "G", "B"}, std::vector<std::vector<float>>(3, std::vector<float>(pixels))};
  for (std::size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < 3; ++c) image.channels[c][i] = rgb[3 * i + c];
  return image;
}

files::FloatImage maps_image(const ParameterMaps& maps) {
  return {maps.width, maps.height, {"Cm", "Ch", "Bm", "Che", "flags"}, {maps.cm, maps.ch, maps.bm, maps.che, maps.flags}};
}

}  // namespace

// ---------------------------------------------------------------- relight

RelightSummary relight_to_files(const RelightOptions& options) {
  LoadedMaps loaded = load_maps(options.maps);
  const bool layer_stored = loaded.maps.discrepancy.has_value();
  if (!options.discrepancy_layer) loaded.maps.discrepancy.reset();  // the model alone
  const ParameterMaps& maps = loaded.maps;
  const NamedSpectrum illuminant = illuminant_field(options.illuminant);
  check_out(options.out);
  if (!(options.heat_map_max >= 0) || !std::isfinite(options.heat_map_max))
    throw field_error("heat_map_max", "must be ≥ 0 (0 = automatic)");
  if (options.threads < 0) throw field_error("threads", "must be ≥ 0");
  const int w = maps.width, h = maps.height;
  const std::size_t pixels = static_cast<std::size_t>(w) * h;
  std::optional<files::FloatImage> photo;
  spectral::CameraSensitivity camera;
  if (!options.photograph.empty()) {
    try {
      photo = files::read_exr(options.photograph);
      for (const char* c : {"R", "G", "B"}) photo->channel(c);
    } catch (const files::ImageError& e) {
      throw field_error("photograph", e.what());
    }
    if (photo->width != w || photo->height != h)
      throw field_error("photograph", options.photograph.string() + " is " + std::to_string(photo->width) + "x" +
                                          std::to_string(photo->height) + " but the maps are " + std::to_string(w) +
                                          "x" + std::to_string(h));
    try {
      camera = session::camera_by_name_or_file(options.camera, fs::current_path());
    } catch (const std::exception& e) {
      throw field_error("camera", e.what());
    }
  }

  RelightSummary summary;
  summary.illuminant = illuminant.name;
  summary.width = w, summary.height = h;
  summary.discrepancy_layer = maps.discrepancy.has_value();
  const RelitImage relit = relight(maps, linear_srgb_weights(illuminant.spectrum), options.threads);
  summary.relit_pixels = static_cast<std::size_t>(std::count(relit.valid.begin(), relit.valid.end(), 1));
  files::FloatImage exr = rgb_image(relit.rgb, w, h);
  exr.channel_names.push_back("valid");
  exr.channels.emplace_back(relit.valid.begin(), relit.valid.end());

  ordered_json j;
  j["maps"] = options.maps.string();
  j["illuminant"] = illuminant.name;
  j["illuminant_given_as"] = options.illuminant;
  j["width"] = w, j["height"] = h;
  j["relit_pixels"] = summary.relit_pixels;
  j["colour_space"] = "linear sRGB (relit.exr), encoded sRGB (relit.png); white albedo = 1";
  j["discrepancy_layer"] = summary.discrepancy_layer ? "model + discrepancy (the maps' posterior discrepancy added)"
                           : layer_stored            ? "model alone (the maps' discrepancy layer turned off)"
                                                     : "model alone (the maps carry no discrepancy layer)";

  files::OutputBatch files(options.out);
  files::write_exr(files.temporary("relit.exr"), exr);
  write_png(files.temporary("relit.png").string(), srgb_preview(relit.rgb, w, h, relit.valid));
  if (photo) {
    std::vector<float> photo_rgb(3 * pixels);
    std::vector<Eigen::Vector3d> photograph(pixels), reconstruction(pixels);
    for (int c = 0; c < 3; ++c) {
      const auto& plane = photo->channel(std::string(1, "RGB"[c]));
      for (std::size_t i = 0; i < pixels; ++i) photo_rgb[3 * i + c] = plane[i];
    }
    const RelitImage camera_relit = relight(maps, spectral::camera_weights(camera, illuminant.spectrum), options.threads);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (std::size_t i = 0; i < pixels; ++i) {
      photograph[i] = {photo_rgb[3 * i], photo_rgb[3 * i + 1], photo_rgb[3 * i + 2]};
      reconstruction[i] = camera_relit.valid[i] ? Eigen::Vector3d(camera_relit.rgb[3 * i], camera_relit.rgb[3 * i + 1],
                                                                  camera_relit.rgb[3 * i + 2])
                                                : Eigen::Vector3d::Constant(nan);
    }
    const std::vector<double> de = photo_delta_e94_map(photograph, reconstruction, camera, illuminant.spectrum);
    std::vector<double> finite;
    for (double v : de)
      if (std::isfinite(v)) finite.push_back(v);
    summary.compared = true;
    summary.photo_delta_e94 = delta_e_stats(std::move(finite));
    const double top = heat_max(options.heat_map_max, summary.photo_delta_e94);
    const cv::Mat panel = side_by_side(
        {{"photograph (" + illuminant.name + ")", srgb_preview(camera_to_linear_srgb(photo_rgb, camera, illuminant.spectrum), w, h)},
         {"reconstruction", srgb_preview(camera_to_linear_srgb(camera_relit.rgb, camera, illuminant.spectrum), w, h, camera_relit.valid)},
         {"dE94", heat_map_with_bar(de, w, h, top, "dE94")}},
        "dE94 photograph vs reconstruction: " + stats_caption(summary.photo_delta_e94) + "  (" +
            std::to_string(summary.photo_delta_e94.pixels) + " px)");
    write_png(files.temporary("panel.png").string(), panel);
    files::FloatImage de_image{w, h, {"dE94"}, {std::vector<float>(de.begin(), de.end())}};
    files::write_exr(files.temporary("delta_e94.exr"), de_image);
    j["photograph"] = options.photograph.string();
    j["camera"] = options.camera;
    j["photo_delta_e94"] = delta_e_stats_json(summary.photo_delta_e94);
    j["heat_map_max"] = top;
  }
  summary.json = j.dump(2) + "\n";
  files.write_text("relight.json", summary.json);
  summary.files = files.commit();
  return summary;
}

// ---------------------------------------------------------------- flush

namespace {

// The flush's mask (0-1 per pixel, feathered) from its one shape, once the options are checked.
cv::Mat checked_flush_mask(const FlushOptions& options, int w, int h) {
  const int shapes = int(options.ellipse.has_value()) + int(options.polygon.has_value()) + int(!options.mask.empty());
  if (shapes != 1) throw field_error("mask", "give exactly one of ellipse, polygon or a mask file");
  if (!(options.feather_px >= 0) || !std::isfinite(options.feather_px)) throw field_error("feather_px", "must be ≥ 0");
  for (const auto& [name, s] : {std::pair{"scale.cm", options.scale.cm}, std::pair{"scale.ch", options.scale.ch},
                                std::pair{"scale.bm", options.scale.bm}, std::pair{"scale.che", options.scale.che}})
    if (!(s > 0) || !std::isfinite(s)) throw field_error(name, "must be a finite factor > 0");
  cv::Mat mask;
  try {
    if (options.ellipse) mask = ellipse_mask(w, h, *options.ellipse, options.feather_px);
    if (options.polygon) mask = polygon_mask(w, h, *options.polygon, options.feather_px);
  } catch (const std::invalid_argument& e) {
    throw field_error(options.ellipse ? "ellipse" : "polygon", e.what());
  }
  if (!options.mask.empty()) {
    try {
      mask = read_mask_image(options.mask, w, h, options.feather_px);
    } catch (const std::exception& e) {
      throw field_error("mask", e.what());
    }
  }
  if (cv::countNonZero(mask) == 0) throw field_error("mask", "selects no pixel of the " + std::to_string(w) + "x" + std::to_string(h) + " maps");
  return mask;
}

// The maps before and after the edit relit through XYZ: linear sRGB of both,
// and the ΔE94 of the change per pixel (NaN where the maps relight nothing).
struct FlushRelit {
  std::vector<float> srgb_before, srgb_after;
  std::vector<double> change;
  std::vector<std::uint8_t> valid;
};
FlushRelit relight_before_and_after(const ParameterMaps& before, const ParameterMaps& after,
                                    const NamedSpectrum& illuminant, int threads) {
  spectral::CameraWeights xyz_weights;
  for (int k = 0; k < spectral::kGridSize; ++k) {
    spectral::Spectrum impulse;
    impulse[k] = 1.0;
    const spectral::Xyz x = spectral::xyz_of_reflectance(impulse, illuminant.spectrum);
    xyz_weights(0, k) = x.X, xyz_weights(1, k) = x.Y, xyz_weights(2, k) = x.Z;
  }
  const spectral::Xyz white = spectral::white_point(illuminant.spectrum);
  const RelitImage xyz_before = relight(before, xyz_weights, threads);
  const RelitImage xyz_after = relight(after, xyz_weights, threads);
  const std::size_t pixels = static_cast<std::size_t>(before.width) * before.height;
  FlushRelit out{std::vector<float>(3 * pixels), std::vector<float>(3 * pixels),
                 std::vector<double>(pixels, std::numeric_limits<double>::quiet_NaN()), xyz_before.valid};
  for (std::size_t i = 0; i < pixels; ++i) {
    if (!xyz_before.valid[i]) continue;
    const spectral::Xyz a{xyz_before.rgb[3 * i], xyz_before.rgb[3 * i + 1], xyz_before.rgb[3 * i + 2]};
    const spectral::Xyz b{xyz_after.rgb[3 * i], xyz_after.rgb[3 * i + 1], xyz_after.rgb[3 * i + 2]};
    const spectral::Rgb ra = spectral::linear_srgb_from_xyz(a, white), rb = spectral::linear_srgb_from_xyz(b, white);
    out.srgb_before[3 * i] = ra.r, out.srgb_before[3 * i + 1] = ra.g, out.srgb_before[3 * i + 2] = ra.b;
    out.srgb_after[3 * i] = rb.r, out.srgb_after[3 * i + 1] = rb.g, out.srgb_after[3 * i + 2] = rb.b;
    out.change[i] = spectral::delta_e94(spectral::lab_from_xyz(a, white), spectral::lab_from_xyz(b, white));
  }
  return out;
}

// flush.json's text.
std::string flush_json(const FlushOptions& options, const FlushSummary& summary) {
  ordered_json j;
  j["maps"] = options.maps.string();
  j["illuminant"] = summary.illuminant;
  j["scale"] = {{"cm", options.scale.cm}, {"ch", options.scale.ch}, {"bm", options.scale.bm}, {"che", options.scale.che}};
  j["feather_px"] = options.feather_px;
  j["pixels_touched"] = summary.edit.pixels_touched;
  j["values_clamped"] = summary.edit.values_clamped;
  j["clamped_share"] = summary.edit.clamped_share;
  j["clamped"] = {{"cm", summary.edit.clamped_cm}, {"ch", summary.edit.clamped_ch}, {"bm", summary.edit.clamped_bm},
                  {"che", summary.edit.clamped_che}};
  j["change_delta_e94"] = delta_e_stats_json(summary.change_delta_e94);
  return j.dump(2) + "\n";
}

// The PNGs of a flush: the mask, before, after, and the panel of before,
// after with the mask's outline, and the change's ΔE94.
struct FlushPictures {
  cv::Mat mask8, before, after, panel;
};
FlushPictures flush_pictures(const FlushOptions& options, const FlushSummary& summary, const cv::Mat& mask,
                             const FlushRelit& relit, int w, int h) {
  std::string factors;
  for (const auto& [name, factor] : {std::pair{"Cm", options.scale.cm}, std::pair{"Ch", options.scale.ch},
                                     std::pair{"Bm", options.scale.bm}, std::pair{"Che", options.scale.che}})
    if (factor != 1.0) factors += std::string(factors.empty() ? "" : " ") + name + " x" + number(factor);
  FlushPictures out;
  out.before = srgb_preview(relit.srgb_before, w, h, relit.valid);
  out.after = srgb_preview(relit.srgb_after, w, h, relit.valid);
  mask.convertTo(out.mask8, CV_8U, 255.0);
  cv::Mat hard;
  cv::threshold(out.mask8, hard, 127, 255, cv::THRESH_BINARY);
  std::vector<std::vector<cv::Point>> outline;
  cv::findContours(hard, outline, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::Mat after_outlined = out.after.clone();
  cv::drawContours(after_outlined, outline, -1, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  out.panel = side_by_side(
      {{"before (" + summary.illuminant + ")", out.before},
       {"after (mask outline)", after_outlined},
       {"dE94 of the change", heat_map_with_bar(relit.change, w, h, std::max(1.0, summary.change_delta_e94.max), "dE94")}},
      factors + "; clamped " + number(100 * summary.edit.clamped_share, 1) + "%; change dE94 " +
          stats_caption(summary.change_delta_e94));
  return out;
}

}  // namespace

FlushSummary flush_to_files(const FlushOptions& options) {
  LoadedMaps loaded = load_maps(options.maps);
  ParameterMaps& maps = loaded.maps;
  const NamedSpectrum illuminant = illuminant_field(options.illuminant);
  check_out(options.out);
  const int w = maps.width, h = maps.height;
  const cv::Mat mask = checked_flush_mask(options, w, h);

  const ParameterMaps before = maps;
  FlushSummary summary;
  summary.illuminant = illuminant.name;
  summary.edit = scale_parameters(maps, mask, options.scale);
  const FlushRelit relit = relight_before_and_after(before, maps, illuminant, options.threads);
  std::vector<double> touched;
  for (std::size_t i = 0; i < relit.change.size(); ++i)
    if (relit.valid[i] && mask.ptr<float>()[i] > 0 && maps.flags[i] == 0.0f) touched.push_back(relit.change[i]);
  summary.change_delta_e94 = delta_e_stats(touched);

  files::FloatImage edited = loaded.image;
  for (std::size_t c = 0; c < edited.channel_names.size(); ++c) {
    const std::string& name = edited.channel_names[c];
    if (name == "Cm") edited.channels[c] = maps.cm;
    if (name == "Ch") edited.channels[c] = maps.ch;
    if (name == "Bm") edited.channels[c] = maps.bm;
    if (name == "Che") edited.channels[c] = maps.che;
  }
  summary.json = flush_json(options, summary);
  const FlushPictures pictures = flush_pictures(options, summary, mask, relit, w, h);

  files::OutputBatch files(options.out);
  files::write_exr(files.temporary("maps.exr"), edited);
  write_png(files.temporary("mask.png").string(), pictures.mask8);
  write_png(files.temporary("before.png").string(), pictures.before);
  write_png(files.temporary("after.png").string(), pictures.after);
  write_png(files.temporary("panel.png").string(), pictures.panel);
  files.write_text("flush.json", summary.json);
  summary.files = files.commit();
  return summary;
}

// ---------------------------------------------------------------- import maps

namespace {

// The two fitted mappings as curves (imported value → log10 parameter).
cv::Mat mapping_plot(const MonotoneMapping& mapping, const std::string& title) {
  constexpr int kW = 320, kH = 220, kLeft = 50, kBottom = 30, kTop = 25;
  cv::Mat canvas(kH, kW, CV_8UC3, cv::Scalar(255, 255, 255));
  const double x0 = mapping.input.front(), x1 = mapping.input.back();
  const auto [ylo, yhi] = std::minmax_element(mapping.output_log10.begin(), mapping.output_log10.end());
  const double y0 = *ylo - 0.05, y1 = *yhi + 0.05;
  auto point = [&](double x, double y) {
    return cv::Point(kLeft + static_cast<int>((x - x0) / std::max(x1 - x0, 1e-12) * (kW - kLeft - 10)),
                     kH - kBottom - static_cast<int>((y - y0) / (y1 - y0) * (kH - kBottom - kTop)));
  };
  cv::rectangle(canvas, point(x0, y0), point(x1, y1), cv::Scalar(180, 180, 180));
  for (std::size_t k = 1; k < mapping.input.size(); ++k)
    cv::line(canvas, point(mapping.input[k - 1], mapping.output_log10[k - 1]),
             point(mapping.input[k], mapping.output_log10[k]), cv::Scalar(160, 60, 0), 2, cv::LINE_AA);
  auto label = [&](const std::string& s, cv::Point at) {
    cv::putText(canvas, s, at, cv::FONT_HERSHEY_SIMPLEX, 0.38, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  };
  label(title, {kLeft, 16});
  label(number(*yhi, 2), {2, point(x0, *yhi).y + 4});
  label(number(*ylo, 2), {2, point(x0, *ylo).y + 4});
  label(number(x0, 0), {kLeft - 10, kH - 12});
  label(number(x1, 0), {kW - 60, kH - 12});
  label("imported value", {kW / 2 - 40, kH - 12});
  return canvas;
}

cv::Mat stack_rows(const std::vector<cv::Mat>& rows) {
  int width = 0;
  for (const auto& r : rows) width = std::max(width, r.cols);
  std::vector<cv::Mat> padded;
  for (const auto& r : rows) {
    cv::Mat p;
    cv::copyMakeBorder(r, p, 0, 0, 0, width - r.cols, cv::BORDER_CONSTANT, cv::Scalar(255, 255, 255));
    padded.push_back(p);
  }
  cv::Mat out;
  cv::vconcat(padded, out);
  return out;
}

}  // namespace

ImportMapsSummary import_maps_to_files(const ImportMapsOptions& options) {
  if (options.melanin.empty()) throw field_error("melanin", "required");
  if (options.hemoglobin.empty()) throw field_error("hemoglobin", "required");
  if (options.measurement.empty()) throw field_error("measurement", "required");
  check_out(options.out);
  std::string error;
  if (!options.import.IsValid(&error)) throw std::invalid_argument(error);
  const ExternalMaps external = read_external_maps(options.melanin, options.hemoglobin);
  fs::path measurement_file = options.measurement;
  if (fs::is_directory(measurement_file)) measurement_file /= "MEASUREMENT.json";
  session::MeasurementFile measurement;
  try {
    measurement = session::read_measurement_file(measurement_file);
    session::register_images(measurement);
  } catch (const std::exception& e) {  // session::MeasurementFileError, session::RegistrationError
    throw field_error("measurement", e.what());
  }
  if (external.width != measurement.width || external.height != measurement.height)
    throw field_error("melanin", options.melanin.string() + " is " + std::to_string(external.width) + "x" +
                                     std::to_string(external.height) + " but the measurement is " +
                                     std::to_string(measurement.width) + "x" + std::to_string(measurement.height));
  ImportOptions import = options.import;
  if (!options.statistics_mask.empty()) {
    cv::Mat mask;
    try {
      mask = read_mask_image(options.statistics_mask, measurement.width, measurement.height, 0.0);
    } catch (const std::exception& e) {
      throw field_error("statistics_mask", e.what());
    }
    import.statistics_mask.resize(mask.total());
    for (std::size_t i = 0; i < mask.total(); ++i) import.statistics_mask[i] = mask.ptr<float>()[i] > 0.5f;
    if (std::count(import.statistics_mask.begin(), import.statistics_mask.end(), 1) == 0)
      throw field_error("statistics_mask", "selects no pixel");
  }
  ImportMapsSummary summary;
  try {
    summary.result = import_external_maps(external, measurement, import);
  } catch (const session::MeasurementFileError& e) {
    throw field_error("measurement", e.what());
  }
  const ImportResult& r = summary.result;
  const int w = measurement.width, h = measurement.height;
  const session::MeasurementImage& photo = measurement.images.front();

  ordered_json j;
  j["melanin"] = options.melanin.string();
  j["hemoglobin"] = options.hemoglobin.string();
  j["measurement"] = measurement_file.string();
  j["statistics_mask"] = options.statistics_mask.string();
  j["photograph"] = r.photograph_name;
  j["prior_sigma_log10"] = options.import.prior_sigma_log10;
  j["search_4d"] = std::string(estimation::method_name(options.import.search_4d));
  j["compared_pixels"] = r.search_4d.stats.pixels;
  ordered_json table = ordered_json::array();
  for (const MethodResult* m : {&r.mapped_2d, &r.augmented, &r.search_4d})
    table.push_back({{"method", m->name}, {"delta_e94", delta_e_stats_json(m->stats)}});
  j["mean_delta_e94"] = {{"2D mapping", r.mapped_2d.stats.mean},
                         {"augmented", r.augmented.stats.mean},
                         {"4D search", r.search_4d.stats.mean}};
  j["methods"] = table;
  auto mapping_json = [](const MonotoneMapping& m) {
    return ordered_json{{"increasing", m.increasing}, {"input", m.input}, {"output_log10", m.output_log10}};
  };
  j["cm_mapping"] = mapping_json(r.cm_mapping);
  j["ch_mapping"] = mapping_json(r.ch_mapping);
  j["seconds"] = {{"2D mapping", r.seconds_2d}, {"augmented", r.seconds_augmented}, {"4D search", r.seconds_4d}};
  summary.json = j.dump(2) + "\n";

  const double top = heat_max(0, r.mapped_2d.stats);
  auto preview = [&](const std::vector<float>& camera_rgb) {
    return srgb_preview(camera_to_linear_srgb(camera_rgb, measurement.camera, photo.illuminant), w, h, r.compared);
  };
  const cv::Mat reconstructions = side_by_side({{"photograph (" + r.photograph_name + ")", preview(r.photograph_rgb)},
                                                {"2D mapping", preview(r.mapped_2d.camera_rgb)},
                                                {"augmented", preview(r.augmented.camera_rgb)},
                                                {"4D search", preview(r.search_4d.camera_rgb)}});
  const cv::Mat errors = side_by_side(
      {{"dE94 2D mapping", heat_map_with_bar(r.mapped_2d.delta_e94, w, h, top, "dE94")},
       {"dE94 augmented", heat_map_with_bar(r.augmented.delta_e94, w, h, top, "dE94")},
       {"dE94 4D search", heat_map_with_bar(r.search_4d.delta_e94, w, h, top, "dE94")}},
      "mean dE94: 2D mapping " + number(r.mapped_2d.stats.mean) + ", augmented " + number(r.augmented.stats.mean) +
          ", 4D search " + number(r.search_4d.stats.mean) + "  (" + std::to_string(r.search_4d.stats.pixels) + " px" +
          (options.statistics_mask.empty() ? "" : " in the statistics mask") + ")");
  const cv::Mat plots = side_by_side({{"melanin -> Cm", mapping_plot(r.cm_mapping, "log10 Cm")},
                                      {"hemoglobin -> Ch", mapping_plot(r.ch_mapping, "log10 Ch")}});

  files::OutputBatch files(options.out);
  files::write_exr(files.temporary("maps_2d.exr"), maps_image(r.mapped_2d.maps));
  files::write_exr(files.temporary("maps_augmented.exr"), maps_image(r.augmented.maps));
  files::write_exr(files.temporary("maps_4d.exr"), maps_image(r.search_4d.maps));
  write_png(files.temporary("panel.png").string(), stack_rows({reconstructions, errors}));
  write_png(files.temporary("mapping.png").string(), plots);
  files.write_text("comparison.json", summary.json);
  summary.files = files.commit();
  return summary;
}

// ---------------------------------------------------------------- profiles

ExportProfilesSummary export_profiles_to_files(const ExportProfilesOptions& options) {
  const NamedSpectrum illuminant = illuminant_field(options.illuminant);
  std::string error;
  if (!options.axes.IsValid(&error)) throw field_error("axes", error);
  check_out(options.out);
  std::optional<ParameterMaps> maps;
  if (!options.maps.empty()) maps = load_maps(options.maps).maps;
  const estimation::SkinModel model;
  const RadialProfileModel profile_model(model, illuminant.spectrum);
  const ProfileTable table =
      build_profile_table(profile_model, options.axes, illuminant.name, options.threads, options.progress);
  files::OutputBatch files(options.out);
  write_profile_table(files, table);
  ExportProfilesSummary summary;
  summary.entries = options.axes.entry_count();
  summary.radii = table.radius_mm.size();
  summary.worst_plane_integral_error = table.worst_plane_integral_error;
  if (maps) {
    const auto indices = nearest_entry_indices(table, *maps);
    write_index_map(files, *maps, indices);
    summary.unmapped_pixels = static_cast<std::size_t>(std::count(indices.begin(), indices.end(), kNoProfileEntry));
  }
  summary.files = files.commit();
  return summary;
}

}  // namespace chromo::maps
