#include "chromo/maps/region_statistics.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "chromo/estimation/pixel_flags.hpp"
#include "chromo/maps/ome_tiff.hpp"

namespace chromo::maps {

PixelRectangle parse_pixel_rectangle(const std::string& text, const std::string& field) {
  int numbers[4];
  const char* at = text.data();
  const char* end = text.data() + text.size();
  for (int i = 0; i < 4; ++i) {
    const auto [next, error] = std::from_chars(at, end, numbers[i]);
    const bool last = i == 3;
    if (error != std::errc{} || (last ? next != end : (next == end || *next != ',')))
      throw std::invalid_argument(field + ": \"" + text + "\" is not x,y,width,height (four integers, map pixels)");
    at = last ? next : next + 1;
  }
  if (numbers[2] <= 0 || numbers[3] <= 0)
    throw std::invalid_argument(field + ": \"" + text + "\": width and height must be at least 1");
  return {numbers[0], numbers[1], numbers[2], numbers[3]};
}

double percentile_of_sorted(const std::vector<double>& sorted, double percent) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double rank = percent / 100.0 * static_cast<double>(sorted.size() - 1);
  const auto below = static_cast<std::size_t>(std::floor(rank));
  const std::size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (sorted[above] - sorted[below]) * (rank - static_cast<double>(below));
}

RegionStatistics region_statistics(const files::FloatImage& maps, const std::string& channel,
                                   const PixelRectangle& region) {
  const auto found = std::find(maps.channel_names.begin(), maps.channel_names.end(), channel);
  if (found == maps.channel_names.end()) {
    std::string names;
    for (const std::string& name : maps.channel_names) names += (names.empty() ? "" : ", ") + name;
    throw std::invalid_argument("channel: \"" + channel + "\" is not in the file (it has " + names + ")");
  }
  const std::int64_t right = std::int64_t{region.x} + region.width, bottom = std::int64_t{region.y} + region.height;
  if (region.x < 0 || region.y < 0 || region.width <= 0 || region.height <= 0 || right > maps.width ||
      bottom > maps.height)
    throw std::invalid_argument(fmt::format("region: {},{} {}×{} is not inside the {}×{} map", region.x, region.y,
                                            region.width, region.height, maps.width, maps.height));
  const std::vector<float>& values = maps.channels[static_cast<std::size_t>(found - maps.channel_names.begin())];
  // Parameter channels count skin only; the categorical ones count every pixel with a value.
  const bool categorical = channel == "flags" || channel == "order";
  const auto flags_at = std::find(maps.channel_names.begin(), maps.channel_names.end(), "flags");
  const std::vector<float>* flags =
      flags_at == maps.channel_names.end() ? nullptr : &maps.channels[static_cast<std::size_t>(flags_at - maps.channel_names.begin())];
  RegionStatistics s;
  s.channel = channel;
  s.unit = map_channel_info(channel).unit;
  s.region = region;
  s.region_pixels = std::int64_t{region.width} * region.height;
  std::vector<double> counted;
  counted.reserve(static_cast<std::size_t>(s.region_pixels));
  using estimation::PixelFlag;
  for (int y = region.y; y < bottom; ++y)
    for (int x = region.x; x < right; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(maps.width) + static_cast<std::size_t>(x);
      const float v = values[i];
      const float flag = flags ? (*flags)[i] : 0.0f;
      if (!std::isfinite(v) || (std::isfinite(flag) && outside_the_skin(static_cast<PixelFlag>(static_cast<int>(flag))))) {
        ++s.outside_field_pixels;
        continue;
      }
      if (!categorical && flag != static_cast<float>(PixelFlag::kExplained) &&
          flag != static_cast<float>(PixelFlag::kSpecular)) {
        ++s.flagged_pixels;
        continue;
      }
      counted.push_back(v);
    }
  s.pixels = static_cast<std::int64_t>(counted.size());
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (counted.empty()) {
    s.mean = s.sd = s.min = s.max = s.p1 = s.p5 = s.p25 = s.median = s.p75 = s.p95 = s.p99 = kNaN;
    return s;
  }
  double sum = 0;
  for (double v : counted) sum += v;
  s.mean = sum / static_cast<double>(counted.size());
  double squares = 0;
  for (double v : counted) squares += (v - s.mean) * (v - s.mean);
  s.sd = counted.size() > 1 ? std::sqrt(squares / static_cast<double>(counted.size() - 1)) : 0.0;
  std::sort(counted.begin(), counted.end());
  s.min = counted.front(), s.max = counted.back();
  s.p1 = percentile_of_sorted(counted, 1), s.p5 = percentile_of_sorted(counted, 5);
  s.p25 = percentile_of_sorted(counted, 25), s.median = percentile_of_sorted(counted, 50);
  s.p75 = percentile_of_sorted(counted, 75), s.p95 = percentile_of_sorted(counted, 95);
  s.p99 = percentile_of_sorted(counted, 99);
  return s;
}

std::string region_statistics_csv(const std::vector<RegionStatistics>& rows) {
  std::string csv =
      "channel,unit,x,y,width,height,region_pixels,pixels,flagged_pixels,outside_field_pixels,mean,sd,min,p1,p5,p25,"
      "median,p75,p95,p99,max\n";
  for (const RegionStatistics& s : rows)
    csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", s.channel, s.unit, s.region.x,
                       s.region.y, s.region.width, s.region.height, s.region_pixels, s.pixels, s.flagged_pixels,
                       s.outside_field_pixels, s.mean, s.sd, s.min, s.p1, s.p5, s.p25, s.median, s.p75, s.p95, s.p99,
                       s.max);
  return csv;
}

}  // namespace chromo::maps
