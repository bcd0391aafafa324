#include "map_display.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#include "chromo/maps/region_statistics.hpp"
#include "maps_folder.hpp"

namespace chromo::daemon::services::maps_api {

namespace pb = chromosphere::v1;
using grpc::StatusCode;

void delta_e_to_proto(const maps::DeltaEStats& s, pb::DeltaEStatistics* out) {
  out->set_mean(s.mean), out->set_median(s.median), out->set_p95(s.p95), out->set_max(s.max);
  out->set_pixels(s.pixels);
}

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
void check_display_width(const char* field, std::uint32_t width, const char* zero_means) {
  if (width < 16 || width > 1024)
    throw Refusal{{StatusCode::INVALID_ARGUMENT, std::string(field) + ": must be 16-1024 (" + zero_means + ")"}};
}
void set_packed(const std::vector<float>& values, std::string* bytes) {
  static_assert(std::endian::native == std::endian::little);
  bytes->assign(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
}

}  // namespace chromo::daemon::services::maps_api
