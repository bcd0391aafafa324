// MapsService: relight, flush, import-maps and profile export on session files (services.hpp, docs/maps.md).
#include <filesystem>
#include <string>

#include "chromo/maps/map_operations.hpp"
#include "chromosphere/v1/maps.grpc.pb.h"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

namespace fs = std::filesystem;
namespace pb = chromosphere::v1;
using grpc::ServerContext;
using grpc::Status;
using grpc::StatusCode;

constexpr std::size_t kMaxPathBytes = 4096;

// A refused request: INVALID_ARGUMENT or NOT_FOUND with the field's name.
struct Refusal {
  Status status;
};

// The library names fields as the command line does; the API's names differ.
std::string api_message(const std::string& message) {
  static const std::pair<const char*, const char*> kNames[] = {
      {"maps: ", "maps_file: "},         {"photograph: ", "photograph_file: "},
      {"mask: ", "mask_file: "},         {"melanin: ", "melanin_file: "},
      {"hemoglobin: ", "hemoglobin_file: "}, {"measurement: ", "measurement_file: "},
      {"out: ", "out_dir: "},           {"statistics_mask: ", "statistics_mask_file: "}};
  for (const auto& [library, api] : kNames)
    if (message.rfind(library, 0) == 0) return api + message.substr(std::string(library).size());
  return message;
}

class Files {
 public:
  Files(Daemon& daemon, const std::string& session_id) {
    if (session_id.empty()) return;
    if (session_id.size() > 128) throw Refusal{{StatusCode::INVALID_ARGUMENT, "session_id: longer than 128 bytes"}};
    for (char c : session_id)
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '+' || c == '.' || c == '-'))
        throw Refusal{{StatusCode::INVALID_ARGUMENT, "session_id: not an id ([A-Za-z0-9_+.-])"}};
    if (!daemon.session(session_id))
      throw Refusal{{StatusCode::NOT_FOUND, "session_id: no session \"" + session_id + "\""}};
    folder_ = daemon.config().sessions_dir / session_id;
  }

  // "" stays "" unless required.
  fs::path resolve(const std::string& field, const std::string& value, bool required) const {
    if (value.empty()) {
      if (required) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": required"}};
      return {};
    }
    if (value.size() > kMaxPathBytes) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": longer than 4096 bytes"}};
    if (value.find('\0') != std::string::npos) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": contains NUL"}};
    const fs::path path(value);
    if (folder_.empty()) {
      if (!path.is_absolute())
        throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": must be an absolute path when session_id is empty"}};
      return path.lexically_normal();
    }
    if (path.is_absolute())
      throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": must be relative to the session folder"}};
    for (const auto& part : path)
      if (part == "..") throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": must not contain \"..\""}};
    return (folder_ / path).lexically_normal();
  }

 private:
  fs::path folder_;
};

// Illuminant names that are files follow the path rule; names do not.
std::string illuminant_field(const Files& files, const std::string& value, const char* fallback) {
  if (value.empty()) return fallback;
  if (value.size() > kMaxPathBytes) throw Refusal{{StatusCode::INVALID_ARGUMENT, "illuminant: longer than 4096 bytes"}};
  const bool looks_like_file = value.find('/') != std::string::npos || value.find('.') != std::string::npos;
  return looks_like_file ? files.resolve("illuminant", value, true).string() : value;
}

void to_proto(const maps::DeltaEStats& s, pb::DeltaEStatistics* out) {
  out->set_mean(s.mean), out->set_median(s.median), out->set_p95(s.p95), out->set_max(s.max);
  out->set_pixels(s.pixels);
}

template <typename Response>
void add_files(const std::vector<fs::path>& files, Response* response) {
  for (const auto& f : files) response->add_files(f.string());
}

double scale_field(double value, const char* field) {
  if (value == 0) return 1.0;
  if (!(value > 0) || !std::isfinite(value)) throw Refusal{{StatusCode::INVALID_ARGUMENT, std::string(field) + ": must be > 0"}};
  return value;
}

class MapsServiceImpl final : public pb::MapsService::Service {
 public:
  MapsServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}

  Status Relight(ServerContext* context, const pb::RelightRequest* request, pb::RelightResponse* response) override {
    return run(context, [&] {
      const Files files(daemon_, request->session_id());
      maps::RelightOptions o;
      o.maps = files.resolve("maps_file", request->maps_file(), true);
      if (request->illuminant().empty()) throw Refusal{{StatusCode::INVALID_ARGUMENT, "illuminant: required"}};
      o.illuminant = illuminant_field(files, request->illuminant(), "");
      o.out = files.resolve("out_dir", request->out_dir(), true);
      o.photograph = files.resolve("photograph_file", request->photograph_file(), false);
      if (!request->camera().empty()) {
        const bool builtin = request->camera().rfind("builtin:", 0) == 0;
        o.camera = builtin ? request->camera() : files.resolve("camera", request->camera(), true).string();
      }
      o.heat_map_max = request->heat_map_max();
      const auto s = maps::relight_to_files(o);
      response->set_illuminant(s.illuminant);
      response->set_width(s.width), response->set_height(s.height);
      response->set_relit_pixels(s.relit_pixels);
      response->set_compared(s.compared);
      to_proto(s.photo_delta_e94, response->mutable_photo_delta_e94());
      add_files(s.files, response);
      response->set_summary_json(s.json);
    });
  }

  Status Flush(ServerContext* context, const pb::FlushRequest* request, pb::FlushResponse* response) override {
    return run(context, [&] {
      const Files files(daemon_, request->session_id());
      maps::FlushOptions o;
      o.maps = files.resolve("maps_file", request->maps_file(), true);
      o.out = files.resolve("out_dir", request->out_dir(), true);
      o.illuminant = illuminant_field(files, request->illuminant(), "D65");
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
          o.mask = files.resolve("mask_file", request->mask_file(), true);
          break;
        default:
          throw Refusal{{StatusCode::INVALID_ARGUMENT, "region: give ellipse, polygon or mask_file"}};
      }
      const auto r = maps::flush_to_files(o);
      response->set_pixels_touched(r.edit.pixels_touched);
      response->set_values_clamped(r.edit.values_clamped);
      response->set_clamped_share(r.edit.clamped_share);
      to_proto(r.change_delta_e94, response->mutable_change_delta_e94());
      add_files(r.files, response);
      response->set_summary_json(r.json);
    });
  }

  Status ImportMaps(ServerContext* context, const pb::ImportMapsRequest* request, pb::ImportMapsResponse* response) override {
    return run(context, [&] {
      const Files files(daemon_, request->session_id());
      maps::ImportMapsOptions o;
      if (!request->search_4d().empty()) {
        const auto search = estimation::parse_method_name(request->search_4d());
        if (!search || *search == estimation::InverterMethod::k2d)
          throw Refusal{{StatusCode::INVALID_ARGUMENT, "search_4d: must be \"fast\" or \"exhaustive\""}};
        o.import.search_4d = *search;
      }
      o.melanin = files.resolve("melanin_file", request->melanin_file(), true);
      o.hemoglobin = files.resolve("hemoglobin_file", request->hemoglobin_file(), true);
      o.measurement = files.resolve("measurement_file", request->measurement_file(), true);
      o.out = files.resolve("out_dir", request->out_dir(), true);
      o.statistics_mask = files.resolve("statistics_mask_file", request->statistics_mask_file(), false);
      if (request->prior_sigma_log10() != 0) o.import.prior_sigma_log10 = request->prior_sigma_log10();
      const auto s = maps::import_maps_to_files(o);
      to_proto(s.result.mapped_2d.stats, response->mutable_mapped_2d());
      to_proto(s.result.augmented.stats, response->mutable_augmented());
      to_proto(s.result.search_4d.stats, response->mutable_search_4d());
      response->set_melanin_increasing(s.result.cm_mapping.increasing);
      response->set_hemoglobin_increasing(s.result.ch_mapping.increasing);
      add_files(s.files, response);
      response->set_summary_json(s.json);
    });
  }

  Status ExportProfiles(ServerContext* context, const pb::ExportProfilesRequest* request,
                        pb::ExportProfilesResponse* response) override {
    return run(context, [&] {
      const Files files(daemon_, request->session_id());
      maps::ExportProfilesOptions o;
      o.illuminant = illuminant_field(files, request->illuminant(), "D65");
      o.out = files.resolve("out_dir", request->out_dir(), true);
      o.maps = files.resolve("maps_file", request->maps_file(), false);
      if (request->cm_size() > 0) o.axes.cm.assign(request->cm().begin(), request->cm().end());
      if (request->ch_size() > 0) o.axes.ch.assign(request->ch().begin(), request->ch().end());
      if (request->bm_size() > 0) o.axes.bm.assign(request->bm().begin(), request->bm().end());
      if (request->che_size() > 0) o.axes.che.assign(request->che().begin(), request->che().end());
      if (o.axes.entry_count() > 100000) throw Refusal{{StatusCode::INVALID_ARGUMENT, "cm, ch, bm, che: more than 100000 profiles"}};
      const auto s = maps::export_profiles_to_files(o);
      response->set_entries(s.entries), response->set_radii(s.radii);
      response->set_worst_plane_integral_error(s.worst_plane_integral_error);
      response->set_unmapped_pixels(s.unmapped_pixels);
      add_files(s.files, response);
    });
  }

 private:
  template <typename Body>
  Status run(ServerContext* context, Body&& body) {
    return guard_(context, [&]() -> Status {
      try {
        body();
        return Status::OK;
      } catch (const Refusal& refusal) {
        return refusal.status;
      } catch (const std::invalid_argument& e) {
        return {StatusCode::INVALID_ARGUMENT, api_message(e.what())};
      }
    });
  }
  Daemon& daemon_;
  Guard& guard_;
};

}  // namespace

std::unique_ptr<grpc::Service> make_maps_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<MapsServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
