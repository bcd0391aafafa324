#include "chromo/maps/estimate_report.hpp"

#include "report_extras.hpp"

#include "chromo/estimation/inverter.hpp"

#include <algorithm>
#include <chrono>
#include <future>
#include <cmath>
#include <limits>
#include <map>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "chromo/estimation/highlight_flags.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/maps/map_panels.hpp"
#include "chromo/maps/map_previews.hpp"
#include "chromo/maps/ome_tiff.hpp"
#include "chromo/maps/relit_table.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/files/binary_cache.hpp"
#include "chromo/maps/white_target_pixels.hpp"
#include "delta_e_json.hpp"

namespace chromo::maps {

namespace fs = std::filesystem;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Pixels that are not skin (`where`: outside the camera's footprint of a
// white reference, or the white target itself): no parameters (NaN), `flag`.
void mark_not_skin(std::span<const std::uint8_t> where, estimation::PixelFlag flag,
                   std::vector<estimation::PixelEstimate>& estimates, estimation::EstimateSummary& summary) {
  if (where.size() != estimates.size()) return;
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    if (!where[i] || estimation::outside_the_skin(estimates[i].flag)) continue;
    estimation::PixelEstimate& e = estimates[i];
    --summary.flag_counts[static_cast<int>(e.flag)];
    if (e.order == 2) --summary.order2;
    if (e.order == 4) --summary.order4;
    e = estimation::PixelEstimate{};
    e.parameters = {kNaN, kNaN, kNaN, kNaN};
    e.residual = kNaN;
    e.flag = flag;
    ++summary.flag_counts[static_cast<int>(e.flag)];
  }
}

std::vector<int> skipped_levels(std::uint32_t mask) {
  std::vector<int> levels;
  for (int l = 31; l > 0; --l)
    if (mask & (1u << l)) levels.push_back(l);
  return levels;
}

}  // namespace

nlohmann::ordered_json registration_report(std::span<const session::RegistrationReport> registration) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const auto& r : registration)
    out.push_back({{"image", r.image},
                   {"reference", r.reference},
                   {"channel", r.channel},
                   {"shift_x_px", r.result.shift_x_px},
                   {"shift_y_px", r.result.shift_y_px},
                   {"rotation_deg", r.result.rotation_deg},
                   {"correlation", r.result.correlation},
                   {"motion_px", r.motion_px},
                   {"warped", r.warped},
                   {"residual_motion_px", r.result.residual_motion_px},
                   {"motion_noise_px", r.result.motion_noise_px},
                   {"skipped_pyramid_levels", skipped_levels(r.result.skipped_levels)},
                   {"method", session::registration_method_name(r.result.method)},
                   {"translation_sigma_px", r.result.translation_sigma_px},
                   {"residual_method", session::registration_method_name(r.result.residual_method)}});
  return out;
}

nlohmann::ordered_json skin_denoise_report(const std::optional<estimation::SkinDenoiseOptions>& options,
                                           const estimation::SkinRefit* refit) {
  nlohmann::ordered_json r{{"enabled", options.has_value()}};
  if (!options) return r;
  r["radius_px"] = options->radius_px;
  r["agreement_quantile"] = options->agreement_quantile;
  if (refit) {
    r["refitted_pixels"] = refit->refitted;
    r["mean_pixels_averaged"] = refit->mean_joined;
    r["seconds"] = refit->seconds;
  }
  return r;
}

nlohmann::ordered_json neighbourhood_report(bool flags, bool order_pooling,
                                            const estimation::NeighbourhoodSummary& summary) {
  return nlohmann::ordered_json{{"flags", flags},
                                {"order_pooling", order_pooling},
                                {"flagged_touching_flagged_regions", summary.flagged_touching},
                                {"flagged_enclosed", summary.flagged_holes},
                                {"block_px", summary.block_px},
                                {"order_changed_to_4", summary.order_to_4},
                                {"order_changed_to_2", summary.order_to_2}};
}

std::vector<ChannelSnr> channel_snr(const estimation::MeasurementSet& set, std::span<const float> measured,
                                    std::span<const estimation::PixelEstimate> estimates, double white_reflectance) {
  const std::size_t channels = static_cast<std::size_t>(set.size());
  std::vector<double> sum(channels, 0.0);
  std::size_t skin = 0;
  for (std::size_t i = 0; i < estimates.size() && (i + 1) * channels <= measured.size(); ++i) {
    if (estimates[i].flag != estimation::PixelFlag::kExplained) continue;
    bool finite = true;
    for (std::size_t c = 0; c < channels; ++c) finite = finite && std::isfinite(measured[i * channels + c]);
    if (!finite) continue;
    for (std::size_t c = 0; c < channels; ++c) sum[c] += measured[i * channels + c];
    ++skin;
  }
  std::vector<ChannelSnr> out;
  for (std::size_t c = 0; c < channels; ++c) {
    const auto& noise = set.channels[c].noise;
    ChannelSnr r;
    r.channel = set.channels[c].name;
    r.white = white_reflectance / std::sqrt(noise.variance(white_reflectance));
    r.skin_pixels = skin;
    r.skin_albedo = skin ? sum[c] / static_cast<double>(skin) : std::numeric_limits<double>::quiet_NaN();
    r.skin = skin ? r.skin_albedo / std::sqrt(noise.variance(r.skin_albedo)) : std::numeric_limits<double>::quiet_NaN();
    out.push_back(std::move(r));
  }
  return out;
}

namespace {

// The σ maps in words: each parameter's median 1σ over the explained pixels,
// and the share of them whose Ch and Che the data cannot separate
// (|correlation| > kInseparableCorrelation).
constexpr double kInseparableCorrelation = 0.9;
nlohmann::ordered_json uncertainty_summary(std::span<const estimation::PixelEstimate> estimates) {
  std::vector<float> sigma[4];
  std::size_t inseparable = 0, counted = 0;
  for (const estimation::PixelEstimate& e : estimates) {
    if (e.flag != estimation::PixelFlag::kExplained || !std::isfinite(e.sigma[0])) continue;
    ++counted;
    for (int p = 0; p < 4; ++p) sigma[p].push_back(e.sigma[p]);
    inseparable += std::abs(e.ch_che_correlation) > kInseparableCorrelation;
  }
  nlohmann::ordered_json out;
  out["pixels"] = counted;
  const char* names[4] = {"Cm", "Ch", "Bm", "Che"};
  nlohmann::ordered_json median;
  for (int p = 0; p < 4; ++p) {
    if (sigma[p].empty()) {
      median[names[p]] = nullptr;
      continue;
    }
    std::nth_element(sigma[p].begin(), sigma[p].begin() + sigma[p].size() / 2, sigma[p].end());
    median[names[p]] = sigma[p][sigma[p].size() / 2];
  }
  out["median_sigma"] = median;
  out["ch_che_inseparable_share"] = counted ? static_cast<double>(inseparable) / counted : 0.0;
  out["ch_che_inseparable_when"] = "|corr_Ch_Che| > 0.9";
  return out;
}

}  // namespace

namespace {

// maps.exr's channels, which pixels the previews hide, and the fitted pixels' residuals (sorted).
struct ReportMaps {
  files::FloatImage maps;
  std::vector<std::uint8_t> hide;
  std::vector<double> residuals;
  // The residual at quantile q (0 without fitted pixels).
  double residual_quantile(double q) const {
    return residuals.empty() ? 0.0
                             : residuals[std::min(residuals.size() - 1, std::size_t(q * (residuals.size() - 1) + 0.5))];
  }
};

ReportMaps report_maps(const EstimateReport& report) {
  const std::size_t pixels = static_cast<std::size_t>(report.width) * report.height;
  if (report.estimates.size() != pixels) throw std::invalid_argument("estimate report: estimates do not fill the image");
  ReportMaps out;
  files::FloatImage& maps = out.maps;
  maps.width = report.width, maps.height = report.height;
  // The parameters, the fit, and each parameter's 1σ with the Ch-Che
  // correlation (estimator.hpp, PixelEstimate::sigma; docs/formats/measurement.md).
  maps.channel_names = {"Cm",       "Ch",       "Bm",       "Che",       "residual",   "order",
                        "flags",    "sigma_Cm", "sigma_Ch", "sigma_Bm", "sigma_Che", "corr_Ch_Che"};
  constexpr int kMapChannels = 12;
  maps.channels.assign(kMapChannels, std::vector<float>(pixels));
  out.hide.resize(pixels);
  for (std::size_t i = 0; i < pixels; ++i) {
    const estimation::PixelEstimate& e = report.estimates[i];
    const float values[kMapChannels] = {float(e.parameters.cm), float(e.parameters.ch), float(e.parameters.bm),
                                        float(e.parameters.che), e.residual, float(e.order),
                                        float(static_cast<int>(e.flag)), e.sigma[0], e.sigma[1], e.sigma[2], e.sigma[3],
                                        e.ch_che_correlation};
    for (int c = 0; c < kMapChannels; ++c) maps.channels[c][i] = values[c];
    out.hide[i] = estimation::outside_the_skin(e.flag) || !std::isfinite(e.parameters.cm) ? kPreviewOutsideField
                  : e.flag != estimation::PixelFlag::kExplained && e.flag != estimation::PixelFlag::kSpecular ? kPreviewMasked
                                                                                                            : kPreviewShown;
    if (e.order > 0) out.residuals.push_back(e.residual);
  }
  for (const auto& [name, values] : report.extra_channels) {
    if (values.size() != pixels) throw std::invalid_argument("estimate report: channel " + name + " does not fill the image");
    maps.channel_names.push_back(name);
    maps.channels.push_back(values);
  }
  if (const DiscrepancyLayer* layer = report.discrepancy_layer) {
    for (const auto& plane : layer->coefficients)
      if (plane.size() != pixels) throw std::invalid_argument("estimate report: the discrepancy layer does not fill the image");
    add_discrepancy_layer(maps, *layer);
  }
  std::sort(out.residuals.begin(), out.residuals.end());
  return out;
}

// summary.json's text: the report's figures, then extra's members.
std::string report_summary_text(const EstimateReport& report, const ReportMaps& maps) {
  const std::size_t pixels = maps.hide.size();
  const std::vector<double>& residuals = maps.residuals;
  double residual_sum = 0;
  for (double r : residuals) residual_sum += r;
  nlohmann::ordered_json s;
  s["method"] = report.method;
  s["model"] = report.model;
  s["width"] = report.width;
  s["height"] = report.height;
  s["channels"] = report.channel_names;
  nlohmann::ordered_json timings = nlohmann::ordered_json::object();
  for (const auto& [name, seconds] : report.timings_s) timings[name] = seconds;
  timings["estimate"] = report.summary.seconds;
  s["timings_s"] = timings;
  s["pixels"] = pixels;
  s["pixels_per_second"] = report.summary.seconds > 0 ? static_cast<double>(pixels) / report.summary.seconds : 0.0;
  s["residual"] = {{"unit", "albedo RMS over channels"},
                   {"mean", residuals.empty() ? 0.0 : residual_sum / static_cast<double>(residuals.size())},
                   {"median", maps.residual_quantile(0.5)},
                   {"p95", maps.residual_quantile(0.95)},
                   {"max", residuals.empty() ? 0.0 : residuals.back()}};
  s["order_counts"] = {{"2", report.summary.order2}, {"4", report.summary.order4}};
  s["uncertainty"] = uncertainty_summary(report.estimates);
  nlohmann::ordered_json flags;
  for (int f = 0; f < estimation::kPixelFlagCount; ++f)
    flags[std::string(estimation::pixel_flag_name(static_cast<estimation::PixelFlag>(f)))] = report.summary.flag_counts[f];
  s["flag_counts"] = flags;
  const nlohmann::ordered_json extra = report_extras(report.extra, "estimate report: extra");
  for (const auto& [key, value] : extra.items()) s[key] = value;
  return s.dump(2) + "\n";
}

struct EncodedFile {
  std::string file;
  std::vector<std::uint8_t> bytes;
};

// The PNG previews (the parameters, residual, σ, flags, order), then the
// report's extra PNGs. The previews are drawn and encoded on other threads
// while this one compresses maps.exr (itself on OpenEXR's pool), which
// `write_maps_exr` commits.
std::vector<EncodedFile> encode_previews_while(const EstimateReport& report, const ReportMaps& report_maps, int threads,
                                               const std::function<void()>& write_maps_exr) {
  const files::FloatImage& maps = report_maps.maps;
  struct Preview {
    const char* file;
    int channel;
    double low, high;
    bool log;
    const char* range_note = "";
  };
  // The parameters over the subject's 1-99th percentile of the shown pixels
  // (the web view's default contrast), the model's range when nothing is shown.
  auto model_preview = [&](const char* file, int channel, const char* name) {
    if (const auto subject = shown_percentile_range(maps.channels[channel], report_maps.hide, 1, 99))
      return Preview{file, channel, subject->first, subject->second, false, " p1-p99"};
    const ModelDisplayRange range = *model_display_range(name);
    return Preview{file, channel, range.low, range.high, range.log_scale, ""};
  };
  const std::vector<Preview> previews = {
      model_preview("cm.png", 0, "Cm"), model_preview("ch.png", 1, "Ch"), model_preview("bm.png", 2, "Bm"),
      model_preview("che.png", 3, "Che"),
      Preview{"residual.png", 4, 0.0, std::max(report_maps.residual_quantile(0.99), 1e-6), false},
      Preview{"sigma_cm.png", 7, 1e-4, 0.1, true},
      Preview{"sigma_ch.png", 8, 1e-4, 0.1, true}};
  std::vector<std::string> flag_names;
  for (int f = 0; f < estimation::kPixelFlagCount; ++f) flag_names.emplace_back(estimation::pixel_flag_name(static_cast<estimation::PixelFlag>(f)));
  std::vector<EncodedFile> encoded(previews.size() + 2);
  for (const auto& [file, bytes] : report.extra_pngs) encoded.push_back({file, bytes});
  auto encode = [&](std::size_t i) {
    if (i >= previews.size() + 2) return;  // encoded already
    if (i < previews.size()) {
      const Preview& p = previews[i];
      const std::string& name = maps.channel_names[p.channel];
      encoded[i] = {p.file, encode_map_png(maps.channels[p.channel], report.width, report.height, p.low, p.high, p.log,
                                           name + p.range_note + "\n" + map_channel_info(name).unit, report_maps.hide,
                                           report.map_pixel_mm)};
    } else if (i == previews.size()) {
      encoded[i] = {"flags.png", encode_category_png(maps.channels[6], report.width, report.height, flag_names)};
    } else {
      encoded[i] = {"order.png",
                    encode_category_png(maps.channels[5], report.width, report.height, {"none", "", "2D", "", "4D"})};
    }
  };
  auto encode_all = [&] {
#pragma omp parallel for schedule(dynamic) num_threads(std::max(1, threads - 1)) if (threads > 2)
    for (std::size_t i = 0; i < previews.size() + 2; ++i) encode(i);
  };
  if (threads > 1) {
    auto previews_done = std::async(std::launch::async, encode_all);
    try {
      write_maps_exr();
    } catch (...) {
      previews_done.wait();
      throw;
    }
    previews_done.get();
  } else {
    write_maps_exr();
    for (std::size_t i = 0; i < previews.size() + 2; ++i) encode(i);
  }
  return encoded;
}

void commit_bytes(const FileCommit& commit, const fs::path& path, std::span<const std::uint8_t> bytes) {
  commit(path, [&](const fs::path& t) {
    std::ofstream out(t, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!out.flush()) throw std::runtime_error("cannot write " + t.string());
  });
}

}  // namespace

std::string write_estimate_report(const fs::path& dir, const EstimateReport& report, const FileCommit& commit,
                                  int writer_threads, std::shared_ptr<const files::FloatImage>* maps_written) {
  const int threads = files::exr_writer_threads(writer_threads);
  ReportMaps maps = report_maps(report);
  const std::string summary_text = report_summary_text(report, maps);
  // ZIP level 1: at 5 MP the same pixels (lossless at every level) in a file 0.3% larger for
  // 16% less CPU than OpenEXR's default 4 (docs/estimation.md "Tables off the estimator's thread").
  constexpr int kMapsZipLevel = 1;
  const files::ExrWriteOptions exr{threads, kMapsZipLevel};
  const std::vector<EncodedFile> encoded = encode_previews_while(report, maps, threads, [&] {
    commit(dir / "maps.exr", [&](const fs::path& t) { files::write_exr(t, maps.maps, exr); });
  });
  // The same channels for Fiji, napari and Python (ome_tiff.hpp).
  commit(dir / "maps.ome.tiff", [&](const fs::path& t) { write_maps_ome_tiff(t, maps.maps, {0, threads}); });
  for (const EncodedFile& e : encoded) commit_bytes(commit, dir / e.file, e.bytes);
  commit_bytes(commit, dir / "summary.json",
               {reinterpret_cast<const std::uint8_t*>(summary_text.data()), summary_text.size()});
  if (maps_written) *maps_written = std::make_shared<const files::FloatImage>(std::move(maps.maps));
  return summary_text;
}

namespace {

// ΔE94 of the means of block×block cells (compare_with_photographs' block_means).
DeltaEStats block_mean_delta_e94(std::span<const std::size_t> included, std::span<const Eigen::Vector3d> photographed,
                                 std::span<const Eigen::Vector3d> reconstructed, int width, int block,
                                 const spectral::CameraSensitivity& camera, const spectral::Spectrum& illuminant) {
  struct Sums {
    Eigen::Vector3d photo = Eigen::Vector3d::Zero(), relit = Eigen::Vector3d::Zero();
    int cells = 0;
  };
  // Blocks row-major (a vector, not a map: 2.4 M look-ups at 5 MP); `included` ascends.
  const auto w = static_cast<std::size_t>(width), b = static_cast<std::size_t>(block);
  const std::size_t columns = (w + b - 1) / b, rows = included.empty() ? 0 : included.back() / w / b + 1;
  std::vector<Sums> blocks(rows * columns);
  for (std::size_t k = 0; k < included.size(); ++k) {
    if (!photographed[k].allFinite() || !reconstructed[k].allFinite()) continue;
    Sums& sums = blocks[included[k] / w / b * columns + included[k] % w / b];
    sums.photo += photographed[k], sums.relit += reconstructed[k], ++sums.cells;
  }
  std::vector<Eigen::Vector3d> photo_means, relit_means;
  for (const Sums& sums : blocks)
    if (2 * sums.cells >= block * block) {
      photo_means.push_back(sums.photo / sums.cells);
      relit_means.push_back(sums.relit / sums.cells);
    }
  return photo_delta_e94(photo_means, relit_means, camera, illuminant);
}

}  // namespace

std::string_view relit_model_name(RelitModel model) { return model == RelitModel::kExact ? "exact" : "table"; }

std::vector<RelitComparison> compare_with_photographs(std::span<const estimation::PixelEstimate> estimates,
                                                      const std::vector<session::Photograph>& photographs,
                                                      const spectral::CameraSensitivity& camera,
                                                      const RelitComparisonOptions& options) {
  for (const auto& photo : photographs)
    if (photo.rgb.size() != estimates.size())
      throw std::invalid_argument("photograph " + photo.name + ": size differs from the maps");
  std::vector<std::size_t> included;
  for (std::size_t i = 0; i < estimates.size(); ++i)
    // Explained pixels only: a specular pixel's parameters are the skin under
    // the reflection, so its reconstruction lacks the highlight by design.
    if (estimates[i].flag == estimation::PixelFlag::kExplained) included.push_back(i);
  // The reconstruction's camera RGB under each illuminant.
  std::vector<std::vector<Eigen::Vector3d>> reconstructed(photographs.size(),
                                                          std::vector<Eigen::Vector3d>(included.size()));
  if (options.model == RelitModel::kTable && !photographs.empty()) {
    std::vector<spectral::Spectrum> illuminants;
    for (const auto& photo : photographs) illuminants.push_back(photo.illuminant);
    std::shared_ptr<const RelitTable> relit = options.prepared;
    if (relit && relit->key() != RelitTable::cache_key(camera, illuminants, options.grid)) relit.reset();
    if (!relit) relit = std::make_shared<const RelitTable>(camera, illuminants, options.grid, options.cache_dir, options.threads);
    const RelitTable& table = *relit;
    std::vector<estimation::SkinParameters> parameters(included.size());
    for (std::size_t k = 0; k < included.size(); ++k) parameters[k] = estimates[included[k]].parameters;
    reconstructed = table.rgb(parameters, options.threads);
  } else {
    // The exact model, chunk by chunk (albedo spectra once per chunk).
    std::vector<spectral::CameraWeights> weights;
    for (const auto& photo : photographs) weights.push_back(spectral::camera_weights(camera, photo.illuminant));
    static const estimation::SkinModel model;
    constexpr std::size_t kChunk = 16384;
    std::vector<estimation::SkinParameters> parameters;
    std::vector<spectral::Spectrum> albedo;
    for (std::size_t begin = 0; begin < included.size(); begin += kChunk) {
      const std::size_t end = std::min(included.size(), begin + kChunk);
      parameters.resize(end - begin);
      albedo.resize(end - begin);
      for (std::size_t k = begin; k < end; ++k) parameters[k - begin] = estimates[included[k]].parameters;
      model.albedo_batch(parameters, albedo, options.threads);
      for (std::size_t p = 0; p < photographs.size(); ++p)
        for (std::size_t k = begin; k < end; ++k) reconstructed[p][k] = weights[p] * albedo[k - begin].values().matrix();
    }
  }
  if (const DiscrepancyLayer* layer = options.discrepancy) {
    // The relit layer: each pixel's posterior discrepancy B c through the camera under the photograph's light.
    Eigen::VectorXd c(layer->basis.terms());
    for (std::size_t p = 0; p < photographs.size(); ++p) {
      const Eigen::Matrix<double, 3, Eigen::Dynamic> seen =
          projected_basis(layer->basis, spectral::camera_weights(camera, photographs[p].illuminant));
      for (std::size_t k = 0; k < included.size(); ++k) {
        layer->at(included[k], c.data());
        reconstructed[p][k] += seen * c;
      }
    }
  }
  std::vector<RelitComparison> out;
  std::vector<Eigen::Vector3d> photographed(included.size());
  auto finite_rms = [](const std::vector<double>& values, std::vector<double>* finite) {
    double sum = 0;
    for (double v : values)
      if (std::isfinite(v)) finite->push_back(v), sum += v * v;
    return finite->empty() ? 0.0 : std::sqrt(sum / static_cast<double>(finite->size()));
  };
  for (std::size_t p = 0; p < photographs.size(); ++p) {
    const session::Photograph& photo = photographs[p];
    for (std::size_t k = 0; k < included.size(); ++k) photographed[k] = photo.rgb[included[k]];
    std::vector<double> compared;
    // The photograph's Lab once, for the comparison and its noise's.
    const std::vector<spectral::Lab> photo_lab = photo_lab_map(photographed, camera, photo.illuminant);
    const double rms =
        finite_rms(delta_e94_map(photo_lab, photo_lab_map(reconstructed[p], camera, photo.illuminant)), &compared);
    RelitComparison comparison{photo.name, delta_e_stats(std::move(compared))};
    if (photo.noise) {
      // Over the pixels compared above (both finite): the photograph's are, and its noisy copy with them.
      std::vector<Eigen::Vector3d> compared_photo;
      std::vector<spectral::Lab> compared_lab;
      for (std::size_t k = 0; k < included.size(); ++k)
        if (photographed[k].allFinite() && reconstructed[p][k].allFinite())
          compared_photo.push_back(photographed[k]), compared_lab.push_back(photo_lab[k]);
      std::vector<double> noise;
      const double noise_rms = finite_rms(
          photograph_noise_delta_e94_map(compared_photo, compared_lab, *photo.noise, camera, photo.illuminant, 1 + p),
          &noise);
      comparison.photograph_noise = delta_e_stats(std::move(noise));
      comparison.beyond_noise_rms = std::sqrt(std::max(0.0, rms * rms - noise_rms * noise_rms));
    }
    if (options.image_width > 0 && options.block_cells > 0)
      comparison.block_means = block_mean_delta_e94(included, photographed, reconstructed[p], options.image_width,
                                                    options.block_cells, camera, photo.illuminant);
    out.push_back(std::move(comparison));
  }
  return out;
}

namespace {

// Where the session's tables are cached (options.cache_dir, else the default).
std::filesystem::path table_cache_dir(const MethodEstimationOptions& options) {
  return options.cache_dir.empty() ? estimation::ForwardTable::default_cache_dir() : options.cache_dir;
}

}  // namespace

estimation::EstimatorOptions default_estimator_options() {
  estimation::EstimatorOptions options;
  options.discrepancy = estimation::ModelDiscrepancy::standard();
  return options;
}

PreparedTables prepare_tables(const estimation::MeasurementSet& set, const MethodEstimationOptions& options,
                              std::span<const PreparedTables* const> earlier,
                              std::span<const spectral::Spectrum> photograph_illuminants) {
  PreparedTables prepared;
  prepared.set = set;
  auto t = std::chrono::steady_clock::now();
  const std::uint64_t key = earlier.empty() ? 0 : estimation::ForwardTable::cache_key(set, options.grid);
  for (const PreparedTables* other : earlier)
    if (other && other->table && other->table->key() == key) prepared.table = other->table;
  if (!prepared.table)
    prepared.table = estimation::ForwardTable::load_or_build(
        set, options.grid, table_cache_dir(options), &prepared.table_rebuilt, options.estimator.threads);
  if (options.relit_model == RelitModel::kTable && !photograph_illuminants.empty()) {
    const std::uint64_t relit_key = RelitTable::cache_key(set.camera, photograph_illuminants, options.grid);
    for (const PreparedTables* other : earlier)
      if (other && other->relit && other->relit->key() == relit_key) prepared.relit = other->relit;
    if (!prepared.relit)
      prepared.relit = std::make_shared<const RelitTable>(set.camera, photograph_illuminants, options.grid,
                                                          table_cache_dir(options), options.estimator.threads);
  }
  prepared.table_seconds = seconds_since(t);
  t = std::chrono::steady_clock::now();
  estimation::EstimatorOptions estimator_options = options.estimator;
  if (estimator_options.cache_dir.empty()) estimator_options.cache_dir = options.cache_dir;  // the inverse table too
  // The pooled order replaces every explained pixel's: the per-pixel rule is then the cheap one (estimator.hpp).
  if (options.neighbourhood.pool_order)
    estimator_options.order_rule = estimation::EstimatorOptions::OrderRule::kLikelihoodRatio;
  prepared.estimator = std::make_shared<const estimation::Estimator>(prepared.table, set, estimator_options);
  prepared.inverter_seconds = seconds_since(t);
  return prepared;
}

bool same_measurement_set(const estimation::MeasurementSet& a, const estimation::MeasurementSet& b) {
  if (a.camera.name != b.camera.name || a.channels.size() != b.channels.size()) return false;
  for (int c = 0; c < 3; ++c)
    if (!(a.camera.rgb[static_cast<std::size_t>(c)].values() == b.camera.rgb[static_cast<std::size_t>(c)].values()).all())
      return false;
  for (std::size_t i = 0; i < a.channels.size(); ++i) {
    const auto &x = a.channels[i], &y = b.channels[i];
    if (x.name != y.name || x.camera_channel != y.camera_channel || !(x.illuminant.values() == y.illuminant.values()).all() ||
        x.noise.read_sigma != y.noise.read_sigma || x.noise.shot_coefficient != y.noise.shot_coefficient ||
        x.noise.white_coefficient != y.noise.white_coefficient || x.noise.saturation_albedo != y.noise.saturation_albedo)
      return false;
  }
  return true;
}

namespace {

// The panel diffuse | surface | combined: the cross D65' photograph (camera
// RGB albedo shown as linear sRGB), the surface map S (inferno, 0 to 0.1 for
// every session, so panels compare: the sheen 0.028 at 28%), and the photograph plus S in every channel (the
// subsurface and surface layers together: what an unpolarised camera sees).
constexpr double kPanelSurfaceMax = 0.1;
std::vector<std::uint8_t> encode_polarisation_panel(const session::Measurement& m) {
  const std::size_t n = m.surface.size();
  std::vector<float> diffuse(3 * n), combined(3 * n);
  const session::Photograph& cross = m.photographs.front();
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      diffuse[3 * i + c] = static_cast<float>(cross.rgb[i][c]);
      combined[3 * i + c] = diffuse[3 * i + c] + (std::isfinite(m.surface[i]) ? std::max(m.surface[i], 0.0f) : 0.0f);
    }
  const std::vector<double> surface(m.surface.begin(), m.surface.end());
  const cv::Mat panel = side_by_side({{"diffuse (cross D65')", srgb_preview(diffuse, m.width, m.height)},
                                      {"surface (parallel - cross)/2", heat_map_with_bar(surface, m.width, m.height, kPanelSurfaceMax, "S")},
                                      {"combined", srgb_preview(combined, m.width, m.height)}});
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", panel, bytes)) throw std::runtime_error("polarisation.png: PNG encoding failed");
  return bytes;
}

// A polarised session's surface map, optical highlight flag and panel; an
// unpolarised one's summary says how highlights were found instead.
struct PolarisationOutputs {
  nlohmann::ordered_json summary;
  std::vector<std::pair<std::string, std::vector<float>>> channels;
  std::vector<std::uint8_t> panel;
};

PolarisationOutputs polarisation_outputs(const session::Measurement& m, const estimation::EstimateSummary& summary) {
  PolarisationOutputs out;
  if (!m.polarised()) {
    out.summary = {{"detection", "heuristic"},
                   {"how", "no parallel-polarised capture: highlights are the estimator's specular flag (a white "
                           "surface reflection removed, pixel_flags.hpp) and the spatial pass's neighbourhood flag"},
                   {"specular_pixels", summary.flag_counts[static_cast<int>(estimation::PixelFlag::kSpecular)]}};
    return out;
  }
  const estimation::HighlightFlags flags = estimation::flag_highlights(m.surface, m.surface_sigma, m.width, m.height);
  const estimation::HighlightFlagOptions rule;
  out.summary = {
      {"detection", "optical"},
      {"how", "D65' parallel − D65' cross (docs/polarisation.md)"},
      {"surface_map", m.surface_correction
                          ? "maps.exr channels surface (G), surface_R, surface_B: (parallel − cross)/(c_parallel − c_cross) per "
                            "channel, the surface layer in albedo units, corrected for the films' extinction"
                          : "maps.exr channels surface (G), surface_R, surface_B: (parallel − cross)/2 per channel, the surface "
                            "layer in albedo units, not corrected for the films' extinction ((ER − 1)²/(ER + 1)² of it: the "
                            "estimator was not given the films)"},
      {"sheen_reference", flags.sheen_reference},
      {"rule", "highlight where (S − sheen_reference) ≥ " + std::to_string(rule.pixel_sigmas) +
                   " σ at the pixel and ≥ " + std::to_string(rule.window_sigmas) + " σ over its 3×3 window"},
      {"flagged_pixels", flags.flagged},
      {"information_only", "maps.exr channel highlight; the diffuse maps there still come from the cross-polarised "
                           "captures, and the flags channel is unchanged"}};
  if (const auto& correction = m.surface_correction) {
    nlohmann::ordered_json cross_factor;
    for (std::size_t k = 0; k < correction->cross_factor.size() && k < m.photographs.size(); ++k)
      cross_factor[m.photographs[k].name] = correction->cross_factor[k];  // per capture, by its name
    out.summary["surface_correction"] = {
        {"films", correction->source},
        {"parallel_minus_cross", correction->parallel_minus_cross},
        {"cross_factor", std::move(cross_factor)},
        {"sheen_reference_rgb", correction->sheen_reference},
        {"rule", "where the G surface map is ≥ " + std::to_string(session::kSurfaceCorrectionSigmas) +
                     " σ above the sheen reference, each cross capture less c_cross·(S − sheen reference) per channel "
                     "(the highlight's surface light); elsewhere as captured (the parameters come from the corrected "
                     "captures; the photographs of relit_delta_e94 are as captured)"},
        {"corrected_pixels", correction->corrected_pixels}};
  }
  std::vector<float> highlight(flags.flag.begin(), flags.flag.end());
  out.channels = {{"surface", m.surface}, {"surface_R", m.surface_red}, {"surface_B", m.surface_blue},
                  {"highlight", std::move(highlight)}};
  out.panel = encode_polarisation_panel(m);
  return out;
}

// The estimates of every pixel, the spatial pass over them, and the pixels
// outside the white's footprint and on the white target marked (result.summary, pixels_per_second set).
struct PixelEstimates {
  std::vector<estimation::PixelEstimate> estimates;
  estimation::NeighbourhoodSummary neighbourhood;
  double neighbourhood_seconds = 0;
  std::optional<estimation::SkinRefit> skin_refit;  // options.skin_denoise set: the multi-pixel estimate
  std::optional<DiscrepancyLayer> discrepancy_layer;  // the relit layer (options.discrepancy_layer_terms > 0)
};
PixelEstimates estimate_pixels(const session::Measurement& m, const estimation::Estimator& estimator,
                               double white_reflectance, const MethodEstimationOptions& options,
                               const files::Progress& progress, MethodEstimationResult& result) {
  PixelEstimates out;
  out.estimates.resize(m.measured.size() / static_cast<std::size_t>(m.set.size()));
  // The white target is known before the fit: its cells are marked, not fitted
  // (a white is far outside the skin's gamut: each took the search path and
  // the specular scan, several times a skin cell's cost, to be flagged).
  const std::vector<std::uint8_t> white_target = white_target_pixels(m.measured, m.set, white_reflectance);
  // The auto model's fit of the order each pixel did not take, for the pooled
  // order to switch to instead of fitting again (same maps bit for bit).
  std::vector<estimation::OtherOrderFit> other(
      options.neighbourhood.pool_order && estimator.options().model == estimation::ModelChoice::kAuto
          ? out.estimates.size()
          : 0);
  result.summary = estimator.estimate(m.measured, out.estimates, progress,
                                      {white_target, estimation::PixelFlag::kWhiteTarget}, other);
  if (result.summary.cancelled) throw std::runtime_error("estimation cancelled");
  result.pixels_per_second =
      result.summary.seconds > 0 ? static_cast<double>(out.estimates.size()) / result.summary.seconds : 0.0;
  // The spatial pass, with the multi-pixel estimate when options.skin_denoise.
  estimation::SpatialPass pass = estimation::spatial_pass(estimator, m.measured, m.width, m.height, out.estimates,
                                                          result.summary, options.neighbourhood, options.skin_denoise,
                                                          other);
  out.neighbourhood = pass.neighbourhood;
  out.neighbourhood_seconds = pass.neighbourhood_seconds;
  out.skin_refit = std::move(pass.skin_refit);
  mark_not_skin(m.no_reference, estimation::PixelFlag::kNoReference, out.estimates, result.summary);
  out.discrepancy_layer = estimate_discrepancy_layer(estimator, m.measured, out.estimates,
                                                     out.skin_refit ? &*out.skin_refit : nullptr,
                                                     options.discrepancy_layer_terms);
  return out;
}

// The relit comparison with the captured photographs.
std::vector<RelitComparison> relit_against_photographs(const session::Measurement& m,
                                                       std::span<const estimation::PixelEstimate> estimates,
                                                       const DiscrepancyLayer* discrepancy_layer,
                                                       const estimation::ForwardTable& table,
                                                       const spectral::CameraSensitivity& camera,
                                                       const MethodEstimationOptions& options,
                                                       std::shared_ptr<const RelitTable> prepared_relit) {
  RelitComparisonOptions relit_options;
  relit_options.model = options.relit_model;
  relit_options.grid = table.grid();
  relit_options.cache_dir = table_cache_dir(options);
  relit_options.prepared = prepared_relit;
  relit_options.threads = options.estimator.threads;
  relit_options.image_width = m.width;
  relit_options.discrepancy = discrepancy_layer;
  return compare_with_photographs(estimates, m.photographs, camera, relit_options);
}

// What summary.json says of the measurement beyond the maps: the table, the
// registration, noise, SNR, the captures, the spatial pass and the relit ΔE94
// (added to extra's members).
nlohmann::ordered_json measurement_report(const session::Measurement& m, const estimation::Estimator& estimator,
                                          const estimation::ForwardTable& table, bool rebuilt, bool in_memory,
                                          const PixelEstimates& pixels, double white_reflectance,
                                          const MethodEstimationOptions& options,
                                          std::span<const RelitComparison> relit_comparisons,
                                          const nlohmann::ordered_json& caller_extra) {
  nlohmann::ordered_json extra = report_extras(caller_extra, "extra");
  extra["table"] = {{"key", files::cache_key_hex(table.key())}, {"nodes", table.grid().node_count()}, {"rebuilt", rebuilt}, {"tables_in_memory", in_memory}};
  // The fast inverter's inverse table in the cache, so deleting the session
  // can remove the entries only it used (docs/daemon.md).
  if (const auto* fast = dynamic_cast<const estimation::FastInverter*>(&estimator.inverter()))
    extra["table"]["inverse_key"] = files::cache_key_hex(fast->inverse_table().key());
  extra["registration"] = registration_report(m.registration);
  extra["registration_tiles"] = options.registration.tile_consensus ? "on" : "off";
  nlohmann::ordered_json noise = nlohmann::ordered_json::object();
  for (const auto& c : m.set.channels)
    noise[c.name] = {{"read_sigma", c.noise.read_sigma},
                     {"shot_coefficient", c.noise.shot_coefficient},
                     {"white_coefficient", c.noise.white_coefficient},
                     {"saturation_albedo", c.noise.saturation_albedo}};
  extra["noise"] = noise;
  nlohmann::ordered_json snr = nlohmann::ordered_json::object();
  for (const auto& c : channel_snr(m.set, m.measured, pixels.estimates, white_reflectance))
    snr[c.channel] = {{"white", c.white}, {"skin", c.skin}, {"skin_albedo", c.skin_albedo}, {"skin_pixels", c.skin_pixels}};
  extra["snr"] = snr;
  nlohmann::ordered_json exposures = nlohmann::ordered_json::array();
  for (const auto& e : m.exposures)
    exposures.push_back({{"capture", e.capture}, {"exposure_us", e.exposure_us}, {"frames", e.frames}});
  extra["captures"] = exposures;
  extra["saturated_pixels"] = m.saturated_pixels;
  extra["no_reference_pixels"] = m.no_reference_pixels;
  extra["neighbourhood"] =
      neighbourhood_report(options.neighbourhood.flags, options.neighbourhood.pool_order, pixels.neighbourhood);
  extra["skin_denoise"] = skin_denoise_report(options.skin_denoise, pixels.skin_refit ? &*pixels.skin_refit : nullptr);
  const DiscrepancyLayer* layer = pixels.discrepancy_layer ? &*pixels.discrepancy_layer : nullptr;
  extra["discrepancy_layer"] = discrepancy_layer_report(layer);
  nlohmann::ordered_json relit = nlohmann::ordered_json::object();
  for (const auto& r : relit_comparisons) relit[r.illuminant] = relit_comparison_json(r);
  extra["relit_delta_e94"] = {
      {"against", m.polarised() ? "the captured cross-polarised photographs (camera RGB albedo → XYZ by the "
                                  "ColorChecker-fitted matrix per illuminant)"
                                : "the captured photographs (camera RGB albedo → XYZ by the ColorChecker-fitted matrix per illuminant)"},
      {"pixels", "explained (flag 0)"},
      {"photograph_noise", "per illuminant: the ΔE94 the photograph's own noise alone gives (its read and shot noise "
                           "from its dark and white); beyond_noise_rms = √max(0, rms² − rms(photograph_noise)²), "
                           "the part of the difference that is not the photograph's noise (unreliable where the "
                           "noise dominates; the D65' photograph is one the maps were fitted to)"},
      {"block_means", "per illuminant: ΔE94 of 8×8-cell block means of the photograph and the reconstruction (linear "
                      "camera RGB, explained cells): the noise averages out, a systematic error (the light, the "
                      "model's floor) stays"},
      {"reconstruction", relit_model_name(options.relit_model)},
      {"layers", layer ? "model + discrepancy (the maps' discrepancy layer added)" : "model"},
      {"by_illuminant", relit}};
  return extra;
}

// Everything after the measurement: tables, estimate, spatial pass, report.
MethodEstimationResult estimate_and_report(const session::Measurement& m, const spectral::CameraSensitivity& camera,
                                           double white_reflectance, std::chrono::steady_clock::time_point start,
                                           double measurement_seconds, const MethodEstimationOptions& options,
                                           const fs::path& out_dir, const FileCommit& commit,
                                           const files::Progress& progress, const nlohmann::ordered_json& caller_extra,
                                           const PreparedTables* prepared) {
  // The tables: kept in memory since the references were in (the on-line
  // estimator), else loaded from the disk cache or built.
  const bool in_memory = prepared && same_measurement_set(prepared->set, m.set);
  PreparedTables loaded;
  // Another set (e.g. the subject's noise at a metered exposure): the
  // prepared forward table still serves where its key is the set's (same
  // camera and illuminants), and the inverse table it holds where its key is.
  const PreparedTables* const earlier[] = {prepared};
  if (!in_memory) loaded = prepare_tables(m.set, options, prepared ? std::span(earlier) : std::span<const PreparedTables* const>());
  const PreparedTables& tables = in_memory ? *prepared : loaded;
  const auto& table = tables.table;
  const estimation::Estimator& estimator = *tables.estimator;
  MethodEstimationResult result;
  const PixelEstimates pixels = estimate_pixels(m, estimator, white_reflectance, options, progress, result);

  auto t = std::chrono::steady_clock::now();
  const DiscrepancyLayer* layer = pixels.discrepancy_layer ? &*pixels.discrepancy_layer : nullptr;
  result.relit = relit_against_photographs(m, pixels.estimates, layer, *table, camera, options, prepared ? prepared->relit : nullptr);
  const double relit_seconds = seconds_since(t);
  const PolarisationOutputs polarisation = polarisation_outputs(m, result.summary);
  result.registration = m.registration;
  result.table_key = table->key();
  nlohmann::ordered_json extra = measurement_report(m, estimator, *table, !in_memory && loaded.table_rebuilt, in_memory,
                                                    pixels, white_reflectance, options, result.relit, caller_extra);

  EstimateReport report;
  report.method = result.inverter = std::string(estimator.inverter().name());
  report.model = std::string(estimation::model_name(options.estimator.model));
  report.width = m.width, report.height = m.height;
  for (const auto& c : m.set.channels) report.channel_names.push_back(c.name);
  report.estimates = pixels.estimates;
  report.summary = result.summary;
  report.discrepancy_layer = layer;
  report.timings_s = {{"measurement_and_registration", measurement_seconds},
                      {"table", in_memory ? 0.0 : loaded.table_seconds},
                      {"inverter_setup", in_memory ? 0.0 : loaded.inverter_seconds},
                      {"neighbourhood", pixels.neighbourhood_seconds},
                      {"relit_comparison", relit_seconds},
                      {"total_before_writing", seconds_since(start)}};
  extra["highlights"] = polarisation.summary;
  result.highlight_detection = polarisation.summary.value("detection", "");
  result.highlight_pixels = polarisation.summary.value(polarisation.channels.empty() ? "specular_pixels" : "flagged_pixels",
                                                       std::uint64_t{0});
  if (options.field_width_mm > 0 && m.width > 0) {
    result.map_pixel_mm = report.map_pixel_mm = options.field_width_mm / m.width;
    extra["map_pixel_mm"] = report.map_pixel_mm;
  }
  report.extra = std::move(extra);
  report.extra_channels = polarisation.channels;
  if (!polarisation.panel.empty()) report.extra_pngs.emplace_back("polarisation.png", polarisation.panel);
  const auto writing = std::chrono::steady_clock::now();
  result.summary_json = write_estimate_report(out_dir, report, commit, options.writer_threads, &result.maps);
  result.timings_s = report.timings_s;
  result.timings_s.insert(result.timings_s.begin() + 3, std::pair<std::string, double>("estimate", result.summary.seconds));
  result.timings_s.emplace_back("writing", seconds_since(writing));
  return result;
}

}  // namespace

double MethodEstimationResult::seconds(const std::string& stage) const {
  for (const auto& [name, value] : timings_s)
    if (name == stage) return value;
  return 0;
}

MethodEstimationResult estimate_measurement(const session::Measurement& measurement,
                                                   const spectral::CameraSensitivity& camera, double white_reflectance,
                                                   double measurement_seconds, const MethodEstimationOptions& options,
                                                   const fs::path& out_dir, const FileCommit& commit,
                                                   const files::Progress& progress, const nlohmann::ordered_json& extra,
                                                   const PreparedTables* prepared) {
  const auto start = std::chrono::steady_clock::now() -
                     std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                         std::chrono::duration<double>(measurement_seconds));
  return estimate_and_report(measurement, camera, white_reflectance, start, measurement_seconds, options, out_dir,
                              commit, progress, extra, prepared);
}

MethodEstimationResult estimate_captures(const session::Captures& captures, const MethodEstimationOptions& options,
                                         const fs::path& out_dir, const FileCommit& commit, const files::Progress& progress,
                                         const nlohmann::ordered_json& extra, const PreparedTables* prepared) {
  const auto start = std::chrono::steady_clock::now();
  const session::Measurement m = session::build_measurement(captures, options.registration);
  return estimate_and_report(m, captures.camera, captures.white_reflectance, start, seconds_since(start), options,
                             out_dir, commit, progress, extra, prepared);
}

}  // namespace chromo::maps
