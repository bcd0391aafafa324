#pragma once
// How MapsService shows a map (maps_service.cpp): the display grid of GetMap
// and CompareSessions' difference map, packed float32 values, a region's
// statistics and ΔE94 statistics into their API messages.

#include <cstdint>
#include <string>
#include <vector>

#include "chromo/files/float_image.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromosphere/v1/maps.grpc.pb.h"

namespace chromo::daemon::services::maps_api {

void delta_e_to_proto(const maps::DeltaEStats& s, chromosphere::v1::DeltaEStatistics* out);

// A region's statistics of one channel into the API's message (Refusal: a
// region or channel the image does not have).
void fill_region_statistics(const chromo::files::FloatImage& image, const std::string& channel,
                            const chromosphere::v1::MapRegion& r, chromosphere::v1::GetRegionStatisticsResponse* response);

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
DisplayGrid display_grid(int source_width, int source_height, std::uint32_t max_width);
// A display width field: 16-1024 cells, else Refusal (INVALID_ARGUMENT) naming it.
void check_display_width(const char* field, std::uint32_t width, const char* zero_means);
// Values as packed little-endian float32 bytes, as this x86/ARM host holds them.
void set_packed(const std::vector<float>& values, std::string* bytes);

}  // namespace chromo::daemon::services::maps_api
