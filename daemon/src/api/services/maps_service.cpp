// MapsService: relight, flush, import-maps and profile export on session files (services.hpp, docs/maps.md).
#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <ctime>
#include <filesystem>
#include <mutex>
#include <optional>
#include <random>
#include <string>

#include "chromo/files/bounded_read.hpp"
#include "chromo/files/decoded_exr_cache.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/estimation/pixel_flags.hpp"
#include "chromo/files/progress.hpp"
#include "chromo/maps/map_operations.hpp"
#include "chromo/maps/map_previews.hpp"
#include "chromo/maps/ome_tiff.hpp"
#include "chromo/maps/photograph_files.hpp"
#include "chromo/maps/region_statistics.hpp"
#include "chromo/maps/session_difference.hpp"
#include "chromosphere/v1/maps.grpc.pb.h"
#include "map_display.hpp"
#include "maps_folder.hpp"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

namespace fs = std::filesystem;
namespace pb = chromosphere::v1;
using grpc::ServerContext;
using grpc::Status;
using grpc::StatusCode;

using namespace maps_api;  // the call's folder (maps_folder.hpp) and how a map is shown (map_display.hpp)

class MapsServiceImpl final : public pb::MapsService::Service {
 public:
  MapsServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}

  Status GetMap(ServerContext* context, const pb::GetMapRequest* request, pb::GetMapResponse* response) override {
    return run(context, request->session_id(), [&](const Folder& files) {
      const std::uint32_t max_width = request->max_width() == 0 ? 320 : request->max_width();
      check_display_width("max_width", max_width, "0: 320");
      const auto decoded = read_maps_file(decoded_maps_, files, request->maps_file());
      const chromo::files::FloatImage& image = *decoded;
      for (const std::string& name : image.channel_names) response->add_channels(name);
      const auto found = std::find(image.channel_names.begin(), image.channel_names.end(), request->channel());
      if (found == image.channel_names.end()) {
        std::string names;
        for (const std::string& name : image.channel_names) names += (names.empty() ? "" : ", ") + name;
        throw Refusal{{StatusCode::INVALID_ARGUMENT, "channel: \"" + request->channel() + "\" is not in the file (it has " + names + ")"}};
      }
      const std::vector<float>& values = image.channels[static_cast<std::size_t>(found - image.channel_names.begin())];
      const auto sigma_found = std::find(image.channel_names.begin(), image.channel_names.end(), "sigma_" + request->channel());
      const std::vector<float>* sigma = sigma_found == image.channel_names.end()
                                            ? nullptr
                                            : &image.channels[static_cast<std::size_t>(sigma_found - image.channel_names.begin())];
      const DisplayGrid grid = display_grid(image.width, image.height, max_width);
      response->set_width(grid.width), response->set_height(grid.height);
      response->set_source_width(image.width), response->set_source_height(image.height);
      const std::vector<float> sampled = grid.sample(values);
      const std::vector<float> sampled_sigma = sigma ? grid.sample(*sigma) : std::vector<float>{};
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      for (const float v : sampled)
        if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
      response->set_min(std::isfinite(lo) ? lo : 0), response->set_max(std::isfinite(hi) ? hi : 0);
      if (request->packed()) {
        set_packed(sampled, response->mutable_values_f32());
        set_packed(sampled_sigma, response->mutable_sigma_f32());
      } else {
        response->mutable_values()->Add(sampled.begin(), sampled.end());
        response->mutable_sigma_values()->Add(sampled_sigma.begin(), sampled_sigma.end());
      }
      response->set_unit(maps::map_channel_info(request->channel()).unit);
      if (const auto range = maps::model_display_range(request->channel())) {
        response->set_model_min(range->low), response->set_model_max(range->high);
        response->set_log_scale(range->log_scale);
      }
      for (int f = 0; f < estimation::kPixelFlagCount; ++f)
        response->add_flag_names(std::string(estimation::pixel_flag_name(static_cast<estimation::PixelFlag>(f))));
    });
  }

  Status GetRegionStatistics(ServerContext* context, const pb::GetRegionStatisticsRequest* request,
                             pb::GetRegionStatisticsResponse* response) override {
    return run(context, request->session_id(), [&](const Folder& files) {
      if (!request->has_region()) throw Refusal{{StatusCode::INVALID_ARGUMENT, "region: required (x, y, width, height)"}};
      const auto decoded = read_maps_file(decoded_maps_, files, request->maps_file());
      const chromo::files::FloatImage& image = *decoded;
      fill_region_statistics(image, request->channel(), request->region(), response);
    });
  }

  Status CompareSessions(ServerContext* context, const pb::CompareSessionsRequest* request,
                         pb::CompareSessionsResponse* response) override {
    return run(context, request->session_id(), [&](const Folder& files) {
      if (!request->has_region()) throw Refusal{{StatusCode::INVALID_ARGUMENT, "region: required (x, y, width, height)"}};
      if (request->map_max_width() > 0) check_display_width("map_max_width", request->map_max_width(), "0: no map");
      const Folder after_files(daemon_, request->after_session_id());  // "" : maps_dir, as session_id
      const auto before = read_maps_file(decoded_maps_, files, request->maps_file());
      const auto after = read_maps_file(decoded_maps_, after_files, request->after_maps_file(), "after_maps_file");
      maps::SessionDifferenceOptions options;
      if (!request->channel().empty()) options.channel = request->channel();
      if (request->threshold_sigma() != 0) options.threshold_sigma = request->threshold_sigma();
      options.register_sessions = !request->no_registration();
      const auto& r = request->region();
      const maps::PixelRectangle region{r.x(), r.y(), r.width(), r.height()};
      maps::SessionDifference d;
      maps::RegionDifference change;
      try {
        d = maps::session_difference(*before, *after, options);
        change = maps::region_difference(d, region, options.threshold_sigma);
      } catch (const std::invalid_argument& e) {
        throw Refusal{{StatusCode::INVALID_ARGUMENT, e.what()}};
      } catch (const session::RegistrationError& e) {
        throw Refusal{{StatusCode::FAILED_PRECONDITION, std::string("registration: ") + e.what()}};
      }
      response->set_channel(options.channel), response->set_threshold_sigma(options.threshold_sigma);
      response->set_shift_x_px(d.registration.shift_x_px), response->set_shift_y_px(d.registration.shift_y_px);
      response->set_rotation_deg(d.registration.rotation_deg), response->set_motion_px(d.motion_px);
      response->set_warped(d.warped);
      response->set_compared_pixels(static_cast<std::uint64_t>(d.compared_pixels));
      response->set_significant_pixels(static_cast<std::uint64_t>(d.significant_pixels));
      fill_region_statistics(*before, options.channel, r, response->mutable_before());
      fill_region_statistics(d.after_registered, options.channel, r, response->mutable_after());
      response->set_region_compared_pixels(static_cast<std::uint64_t>(change.pixels));
      response->set_median_difference(change.median_difference), response->set_sigma_of_median(change.sigma_of_median);
      response->set_z(change.z), response->set_significant(change.significant);
      response->set_mean_difference(change.mean_difference);
      response->set_sigma_of_mean_from_sigma_maps(change.sigma_of_mean);
      if (request->map_max_width() > 0) {
        const DisplayGrid grid = display_grid(d.width, d.height, request->map_max_width());
        response->set_map_width(grid.width), response->set_map_height(grid.height);
        set_packed(grid.sample(d.difference), response->mutable_difference_f32());
        set_packed(grid.sample(d.sigma), response->mutable_sigma_f32());
        set_packed(grid.sample(d.z), response->mutable_z_f32());
      }
    });
  }

  Status ReadMaps(ServerContext* context, const pb::ReadMapsRequest* request,
                  grpc::ServerWriter<pb::ReadMapsResponse>* writer) override {
    return guard_.stream(context, [&]() -> Status {
      return run_body(request->session_id(), [&](const Folder& files) {
        read_maps(files, *request, daemon_.config().max_read_maps_bytes, context, writer);
      });
    });
  }

  Status Relight(ServerContext* context, const pb::RelightRequest* request, pb::RelightResponse* response) override {
    return run(context, request->session_id(), [&](const Folder& files) {
      maps::RelightOptions o;
      o.maps = files.input("maps_file", request->maps_file(), true);
      if (request->illuminant().empty()) throw Refusal{{StatusCode::INVALID_ARGUMENT, "illuminant: required"}};
      o.illuminant = name_or_file(files, "illuminant", request->illuminant(), "");
      o.photograph = files.input("photograph_file", request->photograph_file(), false);
      if (!request->camera().empty()) {
        const bool builtin = request->camera().rfind("builtin:", 0) == 0;
        o.camera = builtin ? request->camera() : files.input("camera", request->camera(), true).string();
      }
      o.out = files.output("relight", request->label());
      o.heat_map_max = request->heat_map_max();
      o.discrepancy_layer = !request->model_only();
      const auto s = maps::relight_to_files(o);
      response->set_illuminant(s.illuminant);
      response->set_width(s.width), response->set_height(s.height);
      response->set_relit_pixels(s.relit_pixels);
      response->set_compared(s.compared);
      delta_e_to_proto(s.photo_delta_e94, response->mutable_photo_delta_e94());
      add_files(files, o.out, s.files, response);
      response->set_summary_json(s.json);
    });
  }

  Status ListPhotographs(ServerContext* context, const pb::ListPhotographsRequest* request,
                         pb::ListPhotographsResponse* response) override {
    return run(context, request->session_id(), [&](const Folder& files) {
      chromo::files::ExrHeader maps_header;
      try {
        maps_header = chromo::files::read_exr_header(files.input("maps_file", request->maps_file(), true));
      } catch (const chromo::files::ImageError& e) {
        throw Refusal{{StatusCode::INVALID_ARGUMENT, "maps_file: " + files.scrub(e.what())}};
      }
      response->set_maps_width(maps_header.width), response->set_maps_height(maps_header.height);
      for (const auto& found : maps::list_photograph_files(files.base(), maps_header.width, maps_header.height)) {
        auto* out = response->add_photographs();
        out->set_file(found.file), out->set_width(found.width), out->set_height(found.height);
        out->set_same_size(found.same_size);
      }
    });
  }

  Status Flush(ServerContext* context, const pb::FlushRequest* request, pb::FlushResponse* response) override {
    return run(context, request->session_id(), [&](const Folder& files) {
      maps::FlushOptions o;
      o.maps = files.input("maps_file", request->maps_file(), true);
      o.illuminant = name_or_file(files, "illuminant", request->illuminant(), "D65");
      const auto& s = request->scale();
      o.scale = {scale_field(s.cm(), "scale.cm"), scale_field(s.ch(), "scale.ch"), scale_field(s.bm(), "scale.bm"),
                 scale_field(s.che(), "scale.che")};
      o.feather_px = request->feather_px();
      switch (request->region_case()) {
        case pb::FlushRequest::kEllipse: {
          const auto& e = request->ellipse();
          o.ellipse = maps::EllipseShape{e.center_x_px(), e.center_y_px(), e.radius_x_px(), e.radius_y_px(),
                                               e.angle_deg()};
          break;
        }
        case pb::FlushRequest::kPolygon: {
          maps::PolygonShape p;
          for (const auto& v : request->polygon().vertices()) p.vertices_px.emplace_back(v.x_px(), v.y_px());
          o.polygon = p;
          break;
        }
        case pb::FlushRequest::kMaskFile:
          o.mask = files.input("mask_file", request->mask_file(), true);
          break;
        default:
          throw Refusal{{StatusCode::INVALID_ARGUMENT, "region: give ellipse, polygon or mask_file"}};
      }
      o.out = files.output("flush", request->label());
      const auto r = maps::flush_to_files(o);
      response->set_pixels_touched(r.edit.pixels_touched);
      response->set_values_clamped(r.edit.values_clamped);
      response->set_clamped_share(r.edit.clamped_share);
      delta_e_to_proto(r.change_delta_e94, response->mutable_change_delta_e94());
      add_files(files, o.out, r.files, response);
      response->set_summary_json(r.json);
    });
  }

  Status ImportMaps(ServerContext* context, const pb::ImportMapsRequest* request, pb::ImportMapsResponse* response) override {
    return run(context, request->session_id(), [&](const Folder& files) {
      maps::ImportMapsOptions o;
      if (!request->search_4d().empty()) {
        const auto search = estimation::parse_method_name(request->search_4d());
        if (!search || *search == estimation::InverterMethod::k2d)
          throw Refusal{{StatusCode::INVALID_ARGUMENT, "search_4d: must be \"fast\" or \"exhaustive\""}};
        o.import.search_4d = *search;
      }
      o.melanin = files.input("melanin_file", request->melanin_file(), true);
      o.hemoglobin = files.input("hemoglobin_file", request->hemoglobin_file(), true);
      o.measurement = files.input("measurement_file", request->measurement_file(), true);
      o.statistics_mask = files.input("statistics_mask_file", request->statistics_mask_file(), false);
      o.out = files.output("import-maps", request->label());
      if (request->prior_sigma_log10() != 0) o.import.prior_sigma_log10 = request->prior_sigma_log10();
      const auto s = maps::import_maps_to_files(o);
      delta_e_to_proto(s.result.mapped_2d.stats, response->mutable_mapped_2d());
      delta_e_to_proto(s.result.augmented.stats, response->mutable_augmented());
      delta_e_to_proto(s.result.search_4d.stats, response->mutable_search_4d());
      response->set_melanin_increasing(s.result.cm_mapping.increasing);
      response->set_hemoglobin_increasing(s.result.ch_mapping.increasing);
      add_files(files, o.out, s.files, response);
      response->set_summary_json(s.json);
    });
  }

  Status ExportProfiles(ServerContext* context, const pb::ExportProfilesRequest* request,
                        pb::ExportProfilesResponse* response) override {
    return run(context, request->session_id(), [&](const Folder& files) {
      maps::ExportProfilesOptions o;
      o.illuminant = name_or_file(files, "illuminant", request->illuminant(), "D65");
      o.maps = files.input("maps_file", request->maps_file(), false);
      if (request->cm_size() > 0) o.axes.cm.assign(request->cm().begin(), request->cm().end());
      if (request->ch_size() > 0) o.axes.ch.assign(request->ch().begin(), request->ch().end());
      if (request->bm_size() > 0) o.axes.bm.assign(request->bm().begin(), request->bm().end());
      if (request->che_size() > 0) o.axes.che.assign(request->che().begin(), request->che().end());
      if (o.axes.entry_count() > 100000) throw Refusal{{StatusCode::INVALID_ARGUMENT, "cm, ch, bm, che: more than 100000 profiles"}};
      // At most max_profile_exports at once (each takes every core), and work
      // its client abandoned (cancelled, or past its deadline) stops at the
      // next profile with nothing written (issue 40, row 7).
      const std::uint32_t limit = daemon_.config().max_profile_exports;
      {
        std::lock_guard lock(exports_mutex_);
        if (exports_running_ >= limit)
          throw Refusal{{StatusCode::RESOURCE_EXHAUSTED, "max_profile_exports: " + std::to_string(limit) +
                                                             " profile export(s) running already; retry when it ends"}};
        ++exports_running_;
      }
      const std::shared_ptr<void> slot(nullptr, [this](void*) {
        std::lock_guard lock(exports_mutex_);
        --exports_running_;
      });
      o.progress.should_cancel = [context] { return context->IsCancelled(); };
      o.out = files.output("profiles", request->label());
      const auto s = maps::export_profiles_to_files(o);
      response->set_entries(s.entries), response->set_radii(s.radii);
      response->set_worst_plane_integral_error(s.worst_plane_integral_error);
      response->set_unmapped_pixels(s.unmapped_pixels);
      add_files(files, o.out, s.files, response);
    });
  }

 private:
  // The body gets the call's folder; library messages lose the folder's
  // own path (a client names files relative to it).
  template <typename Body>
  Status run(ServerContext* context, const std::string& session_id, Body&& body) {
    return guard_(context, [&]() -> Status { return run_body(session_id, body); });
  }
  template <typename Body>
  Status run_body(const std::string& session_id, Body&& body) {
    std::optional<Folder> folder;
    try {
      folder.emplace(daemon_, session_id);
      body(*folder);
      return Status::OK;
    } catch (const Refusal& refusal) {
      return refusal.status;
    } catch (const files::Cancelled&) {
      return {StatusCode::CANCELLED, "cancelled: the client cancelled or its deadline passed; nothing was written"};
    } catch (const std::invalid_argument& e) {
      return {StatusCode::INVALID_ARGUMENT, api_message(folder ? folder->scrub(e.what()) : e.what())};
    } catch (const std::exception& e) {
      return {StatusCode::INTERNAL, folder ? folder->scrub(e.what()) : e.what()};
    }
  }

  // ReadMaps' body: checks every field, then the header, then the rows in chunks.
  static void read_maps(const Folder& files, const pb::ReadMapsRequest& request, std::uint64_t max_bytes,
                        ServerContext* context, grpc::ServerWriter<pb::ReadMapsResponse>* writer) {
    const std::uint32_t chunk_bytes = request.chunk_bytes() == 0 ? (1u << 20) : request.chunk_bytes();
    if (chunk_bytes < (64u << 10) || chunk_bytes > (3u << 20))
      throw Refusal{{StatusCode::INVALID_ARGUMENT, "chunk_bytes: must be 65536-3145728 (0: 1 MiB)"}};
    const std::string maps_file = request.maps_file().empty() ? "results/maps.exr" : request.maps_file();
    const fs::path path = files.input("maps_file", maps_file, true);
    files::ExrSize size;
    files::FloatImage image;
    try {
      size = files::check_exr_file(path);
      image = files::read_exr(path);
    } catch (const files::ImageError& e) {  // not a readable OpenEXR file: the request named it
      throw Refusal{{StatusCode::INVALID_ARGUMENT, "maps_file: " + files.scrub(e.what())}};
    }
    std::vector<std::size_t> sent;
    for (const std::string& name : request.channels()) {
      const auto found = std::find(image.channel_names.begin(), image.channel_names.end(), name);
      if (found == image.channel_names.end()) {
        std::string names;
        for (const std::string& n : image.channel_names) names += (names.empty() ? "" : ", ") + n;
        throw Refusal{{StatusCode::INVALID_ARGUMENT, "channels: \"" + name + "\" is not in " + maps_file + " (it has " + names + ")"}};
      }
      sent.push_back(static_cast<std::size_t>(found - image.channel_names.begin()));
    }
    if (request.channels().empty()) sent = maps::map_channel_order(image.channel_names);
    const std::uint64_t bytes = static_cast<std::uint64_t>(size.width) * size.height * 4 * sent.size();
    if (bytes > max_bytes)
      throw Refusal{{StatusCode::RESOURCE_EXHAUSTED,
                     "channels: " + std::to_string(sent.size()) + " channels of " + maps_file + " (" +
                         std::to_string(size.width) + "x" + std::to_string(size.height) + ") are " + std::to_string(bytes) +
                         " bytes, more than the " + std::to_string(max_bytes) +
                         " one call sends (max_read_maps_bytes); ask for fewer channels"}};
    pb::ReadMapsResponse header;
    header.set_width(static_cast<std::uint32_t>(image.width)), header.set_height(static_cast<std::uint32_t>(image.height));
    for (std::size_t c : sent) {
      const maps::MapChannelInfo info = maps::map_channel_info(image.channel_names[c]);
      auto* channel = header.add_channels();
      channel->set_name(info.name), channel->set_unit(info.unit), channel->set_meaning(info.meaning);
    }
    for (int f = 0; f < estimation::kPixelFlagCount; ++f)
      header.add_flag_names(std::string(estimation::pixel_flag_name(static_cast<estimation::PixelFlag>(f))));
    const std::size_t row_bytes = static_cast<std::size_t>(image.width) * 4 * sent.size();
    const int rows_per_chunk = static_cast<int>(std::max<std::size_t>(1, chunk_bytes / std::max<std::size_t>(1, row_bytes)));
    for (int row = 0; row < image.height; row += rows_per_chunk) {
      if (context->IsCancelled()) return;
      pb::ReadMapsResponse chunk = row == 0 ? std::move(header) : pb::ReadMapsResponse{};
      const int rows = std::min(rows_per_chunk, image.height - row);
      chunk.set_row_begin(static_cast<std::uint32_t>(row)), chunk.set_rows(static_cast<std::uint32_t>(rows));
      for (std::size_t c : sent) {
        const float* begin = image.channels[c].data() + static_cast<std::size_t>(row) * image.width;
        chunk.add_data(reinterpret_cast<const char*>(begin), static_cast<std::size_t>(rows) * image.width * 4);
      }
      if (!writer->Write(chunk)) return;  // the client went away
    }
  }
  Daemon& daemon_;
  Guard& guard_;
  // GetMap's and GetRegionStatistics' decoded maps files: 16 of 320×240 ×
  // 12 channels (3.7 MB each), or one 5-MP camera's.
  chromo::files::DecodedExrCache decoded_maps_{std::uint64_t{64} << 20};
  std::mutex exports_mutex_;
  std::uint32_t exports_running_ = 0;
};

}  // namespace

std::unique_ptr<grpc::Service> make_maps_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<MapsServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
