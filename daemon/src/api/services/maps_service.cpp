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

// The folder a call works in: the session's (<sessions_dir>/<session_id>) or,
// without a session, the configured maps_dir. Inputs are relative paths that
// stay inside it once symbolic links are resolved and name regular files;
// outputs go to a new folder products/<operation>-<UTC time>-<6 hex>[-label]
// of their own. Nothing outside the folder is read, written or described.
class Folder {
 public:
  Folder(Daemon& daemon, const std::string& session_id) {
    if (session_id.empty()) {
      if (daemon.config().maps_dir.empty())
        throw Refusal{{StatusCode::INVALID_ARGUMENT,
                       "session_id: required (this daemon has no maps_dir for work without a session)"}};
      fs::create_directories(daemon.config().maps_dir);
      base_ = fs::canonical(daemon.config().maps_dir);
      what_ = "maps_dir";
      return;
    }
    if (Status s = check_id("session_id", session_id); !s.ok()) throw Refusal{s};
    if (!daemon.session(session_id))
      throw Refusal{{StatusCode::NOT_FOUND, "session_id: no session \"" + session_id + "\""}};
    base_ = fs::canonical(daemon.config().sessions_dir / session_id);
    what_ = "the session folder";
  }

  // An input file; "" stays "" unless required.
  fs::path input(const std::string& field, const std::string& value, bool required) const {
    if (value.empty()) {
      if (required) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": required"}};
      return {};
    }
    if (value.size() > kMaxPathBytes) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": longer than 4096 bytes"}};
    if (value.find('\0') != std::string::npos) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": contains NUL"}};
    const fs::path path(value);
    if (path.is_absolute())
      throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": must be a path relative to " + what_ + ", not absolute"}};
    for (const auto& part : path)
      if (part == "..") throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": must not contain \"..\""}};
    // Every symbolic link on the way must resolve completely, and inside: a
    // link out of the folder reads as the same refusal whether its target
    // exists, is unreadable or is missing.
    const auto outside = [&] { return Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + value + " leads outside " + what_}}; };
    std::error_code error;
    fs::path prefix = base_;
    for (const auto& part : path) {
      prefix /= part;
      if (fs::is_symlink(fs::symlink_status(prefix, error))) {
        const fs::path target = fs::canonical(prefix, error);
        if (error || !inside(target)) throw outside();
      }
    }
    const fs::path resolved = fs::weakly_canonical(base_ / path, error);
    if (error || !inside(resolved)) throw outside();
    const auto status = fs::status(resolved, error);
    if (error || !fs::exists(status)) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + value + ": no such file"}};
    if (!fs::is_regular_file(status))
      throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + value + ": not a regular file"}};
    return resolved;
  }

  // The new output folder of one call (not created: the library creates it
  // and removes it again when the call fails).
  fs::path output(const std::string& operation, const std::string& label) const {
    if (!label.empty() && !session::is_valid_name(label))
      throw Refusal{{StatusCode::INVALID_ARGUMENT, "label: must match [A-Za-z0-9_+.-]{1,64}"}};
    const fs::path products = base_ / "products";
    std::error_code error;
    const auto status = fs::symlink_status(products, error);
    if (fs::exists(status) && !fs::is_directory(status))
      throw Refusal{{StatusCode::FAILED_PRECONDITION, "products: exists in " + what_ + " and is not a folder"}};
    static std::mutex mutex;
    static std::mt19937_64 random{std::random_device{}()};
    std::uint64_t suffix;
    {
      std::lock_guard lock(mutex);
      suffix = random();
    }
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    ::gmtime_r(&now, &utc);
    char name[64];
    std::snprintf(name, sizeof name, "%04d%02d%02dT%02d%02d%02dZ-%06llx", utc.tm_year + 1900, utc.tm_mon + 1, utc.tm_mday,
                  utc.tm_hour, utc.tm_min, utc.tm_sec, static_cast<unsigned long long>(suffix & 0xffffff));
    fs::path out = products / (operation + "-" + name + (label.empty() ? "" : "-" + label));
    if (fs::exists(out, error)) throw Refusal{{StatusCode::ABORTED, "out_dir: " + relative(out) + " exists; retry"}};
    return out;
  }

  const fs::path& base() const { return base_; }

  // A path inside the folder as the client names it.
  std::string relative(const fs::path& path) const { return path.lexically_relative(base_).string(); }
  // A library message with the folder's own path taken out.
  std::string scrub(std::string message) const {
    const std::string prefix = base_.string() + "/";
    for (std::size_t at; (at = message.find(prefix)) != std::string::npos;) message.erase(at, prefix.size());
    return message;
  }

 private:
  bool inside(const fs::path& path) const {
    auto b = base_.begin(), p = path.begin();
    for (; b != base_.end(); ++b, ++p)
      if (p == path.end() || *p != *b) return false;
    return true;
  }
  fs::path base_;
  std::string what_;
};

// Illuminant and camera names that are files follow the input rule; names do not.
std::string name_or_file(const Folder& folder, const char* field, const std::string& value, const char* fallback) {
  if (value.empty()) return fallback;
  if (value.size() > kMaxPathBytes) throw Refusal{{StatusCode::INVALID_ARGUMENT, std::string(field) + ": longer than 4096 bytes"}};
  const bool looks_like_file = value.find('/') != std::string::npos || value.find('.') != std::string::npos;
  return looks_like_file ? folder.input(field, value, true).string() : value;
}

void delta_e_to_proto(const maps::DeltaEStats& s, pb::DeltaEStatistics* out) {
  out->set_mean(s.mean), out->set_median(s.median), out->set_p95(s.p95), out->set_max(s.max);
  out->set_pixels(s.pixels);
}

// The output folder and its files, relative to the call's folder.
template <typename Response>
void add_files(const Folder& folder, const fs::path& out, const std::vector<fs::path>& files, Response* response) {
  response->set_out_dir(folder.relative(out));
  for (const auto& f : files) response->add_files(folder.relative(f));
}

double scale_field(double value, const char* field) {
  if (value == 0) return 1.0;
  if (!(value > 0) || !std::isfinite(value)) throw Refusal{{StatusCode::INVALID_ARGUMENT, std::string(field) + ": must be > 0"}};
  return value;
}

// A maps file named by the request, decoded once while it is unchanged
// (the web view asks GetMap for each channel of one file); a file that is not
// a readable EXR is the request's fault (issue 40: INTERNAL before).
std::shared_ptr<const chromo::files::FloatImage> read_maps_file(chromo::files::DecodedExrCache& cache, const Folder& files,
                                                                 const std::string& maps_file,
                                                                 const std::string& field = "maps_file") {
  try {
    return cache.read(files.input(field, maps_file, true));
  } catch (const chromo::files::ImageError& e) {
    throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + files.scrub(e.what())}};
  } catch (const chromo::files::InputFileError& e) {
    throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + files.scrub(e.what())}};
  }
}

// A region's statistics of one channel into the API's message.
void fill_region_statistics(const chromo::files::FloatImage& image, const std::string& channel, const pb::MapRegion& r,
                            pb::GetRegionStatisticsResponse* response) {
  maps::RegionStatistics s;
  try {
    s = maps::region_statistics(image, channel, {r.x(), r.y(), r.width(), r.height()});
  } catch (const std::invalid_argument& e) {
    throw Refusal{{StatusCode::INVALID_ARGUMENT, e.what()}};
  }
  response->set_channel(s.channel), response->set_unit(s.unit);
  *response->mutable_region() = r;
  response->set_region_pixels(s.region_pixels), response->set_pixels(s.pixels);
  response->set_flagged_pixels(s.flagged_pixels), response->set_outside_field_pixels(s.outside_field_pixels);
  response->set_mean(s.mean), response->set_sd(s.sd), response->set_min(s.min), response->set_max(s.max);
  response->set_p1(s.p1), response->set_p5(s.p5), response->set_p25(s.p25), response->set_median(s.median);
  response->set_p75(s.p75), response->set_p95(s.p95), response->set_p99(s.p99);
  response->set_source_width(image.width), response->set_source_height(image.height);
}

// The cells a map is shown at (GetMap, CompareSessions' difference map): at
// most max_width across (never more than the map's own width), the height in
// the map's aspect; each cell is the map pixel at the cell's centre (no
// averaging: a value shown is a value the map holds).
struct DisplayGrid {
  int width = 0, height = 0;
  std::vector<std::size_t> source_pixel;  // per cell, row-major: the map pixel it shows

  std::vector<float> sample(const std::vector<float>& map) const {
    std::vector<float> cells;
    cells.reserve(source_pixel.size());
    for (const std::size_t at : source_pixel) cells.push_back(map[at]);
    return cells;
  }
};
DisplayGrid display_grid(int source_width, int source_height, std::uint32_t max_width) {
  DisplayGrid grid;
  grid.width = std::min<int>(static_cast<int>(max_width), source_width);
  grid.height = std::max(1, static_cast<int>(std::lround(static_cast<double>(source_height) * grid.width / source_width)));
  grid.source_pixel.reserve(static_cast<std::size_t>(grid.width) * grid.height);
  for (int y = 0; y < grid.height; ++y) {
    const int sy = std::min(source_height - 1, static_cast<int>((y + 0.5) * source_height / grid.height));
    for (int x = 0; x < grid.width; ++x) {
      const int sx = std::min(source_width - 1, static_cast<int>((x + 0.5) * source_width / grid.width));
      grid.source_pixel.push_back(static_cast<std::size_t>(sy) * source_width + sx);
    }
  }
  return grid;
}
// A display width field: 16-1024 cells, else INVALID_ARGUMENT naming it.
void check_display_width(const char* field, std::uint32_t width, const char* zero_means) {
  if (width < 16 || width > 1024)
    throw Refusal{{StatusCode::INVALID_ARGUMENT, std::string(field) + ": must be 16-1024 (" + zero_means + ")"}};
}
// Values as packed little-endian float32 bytes, as this x86/ARM host holds them.
void set_packed(const std::vector<float>& values, std::string* bytes) {
  static_assert(std::endian::native == std::endian::little);
  bytes->assign(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
}

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
