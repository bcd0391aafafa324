#include "chromo/maps/session_difference.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "chromo/estimation/pixel_flags.hpp"

namespace chromo::maps {

namespace {

const std::vector<float>& channel_of(const files::FloatImage& maps, const std::string& name, const char* which) {
  const auto found = std::find(maps.channel_names.begin(), maps.channel_names.end(), name);
  if (found == maps.channel_names.end())
    throw std::invalid_argument(std::string(which) + ": the maps have no channel \"" + name + "\"");
  return maps.channels[static_cast<std::size_t>(found - maps.channel_names.begin())];
}

bool is_skin(float value, float sigma, float flag) {
  return std::isfinite(value) && std::isfinite(sigma) && sigma > 0 &&
         (flag == static_cast<float>(estimation::PixelFlag::kExplained) ||
          flag == static_cast<float>(estimation::PixelFlag::kSpecular));
}

// Cm with the pixels that are not skin set to the skin's median: ECC's
// texture without the holes' edges.
std::vector<float> texture(const files::FloatImage& maps, const char* which) {
  std::vector<float> cm = channel_of(maps, "Cm", which);
  const std::vector<float>& flags = channel_of(maps, "flags", which);
  std::vector<float> skin;
  for (std::size_t i = 0; i < cm.size(); ++i)
    if (is_skin(cm[i], 1.0f, flags[i])) skin.push_back(cm[i]);
  if (skin.empty()) throw std::invalid_argument(std::string(which) + ": no skin pixel to register on");
  std::nth_element(skin.begin(), skin.begin() + static_cast<std::ptrdiff_t>(skin.size() / 2), skin.end());
  const float median = skin[skin.size() / 2];
  for (std::size_t i = 0; i < cm.size(); ++i)
    if (!is_skin(cm[i], 1.0f, flags[i])) cm[i] = median;
  return cm;
}

// The median (the mean of the middle two for an even count); reorders `v`.
double median_of(std::vector<double>& v) {
  const std::size_t half = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(half), v.end());
  if (v.size() % 2) return v[half];
  return 0.5 * (v[half] + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(half)));
}

}  // namespace

SessionDifference session_difference(const files::FloatImage& before, const files::FloatImage& after,
                                     const SessionDifferenceOptions& options) {
  if (before.width != after.width || before.height != after.height)
    throw std::invalid_argument("after: the maps are " + std::to_string(after.width) + "×" + std::to_string(after.height) +
                                ", the before maps " + std::to_string(before.width) + "×" + std::to_string(before.height));
  if (!(options.threshold_sigma > 0)) throw std::invalid_argument("threshold: must be > 0 σ");
  const std::string sigma_name = "sigma_" + options.channel;
  for (const auto* maps : {&before, &after}) {
    const char* which = maps == &before ? "before" : "after";
    channel_of(*maps, options.channel, which), channel_of(*maps, sigma_name, which), channel_of(*maps, "flags", which);
  }
  SessionDifference d;
  d.width = before.width, d.height = before.height;
  d.after_registered = after;
  if (options.register_sessions) {
    d.registration = session::register_channel(texture(before, "before"), texture(after, "after"), d.width, d.height);
    d.motion_px = session::corner_displacement_px(d.registration, d.width, d.height);
    d.warped = session::motion_is_significant(d.registration, d.motion_px);
    if (d.warped)
      for (auto& values : d.after_registered.channels)
        values = session::warp_channel(values, d.width, d.height, d.registration);
  }
  const std::vector<float>& b = channel_of(before, options.channel, "before");
  const std::vector<float>& b_sigma = channel_of(before, sigma_name, "before");
  const std::vector<float>& b_flags = channel_of(before, "flags", "before");
  const std::vector<float>& a = channel_of(d.after_registered, options.channel, "after");
  const std::vector<float>& a_sigma = channel_of(d.after_registered, sigma_name, "after");
  const std::vector<float>& a_flags = channel_of(d.after_registered, "flags", "after");  // a warped flag between codes is no code: not skin
  const std::size_t pixels = b.size();
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  d.difference.assign(pixels, kNaN), d.sigma.assign(pixels, kNaN), d.z.assign(pixels, kNaN);
  d.significant.assign(pixels, 0);
  for (std::size_t i = 0; i < pixels; ++i) {
    if (!is_skin(b[i], b_sigma[i], b_flags[i]) || !is_skin(a[i], a_sigma[i], a_flags[i])) continue;
    d.difference[i] = a[i] - b[i];
    d.sigma[i] = std::hypot(a_sigma[i], b_sigma[i]);
    d.z[i] = d.difference[i] / d.sigma[i];
    d.significant[i] = std::abs(d.z[i]) > options.threshold_sigma;
    ++d.compared_pixels;
    d.significant_pixels += d.significant[i];
  }
  return d;
}

RegionDifference region_difference(const SessionDifference& d, const PixelRectangle& region, double threshold_sigma) {
  if (region.x < 0 || region.y < 0 || region.width <= 0 || region.height <= 0 || region.x + region.width > d.width ||
      region.y + region.height > d.height)
    throw std::invalid_argument("region: " + std::to_string(region.x) + "," + std::to_string(region.y) + "," +
                                std::to_string(region.width) + "," + std::to_string(region.height) +
                                " is not inside the " + std::to_string(d.width) + "×" + std::to_string(d.height) + " maps");
  RegionDifference out;
  std::vector<double> differences;
  double sum = 0, variance_sum = 0;
  for (int y = region.y; y < region.y + region.height; ++y)
    for (int x = region.x; x < region.x + region.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * d.width + x;
      if (!std::isfinite(d.difference[i])) continue;
      differences.push_back(d.difference[i]);
      sum += d.difference[i];
      variance_sum += double(d.sigma[i]) * d.sigma[i];
    }
  out.pixels = static_cast<std::int64_t>(differences.size());
  if (differences.empty()) {
    out.median_difference = out.z = out.mean_difference = std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  const double n = static_cast<double>(differences.size());
  out.mean_difference = sum / n;
  out.sigma_of_mean = std::sqrt(variance_sum) / n;
  out.median_difference = median_of(differences);
  for (double& v : differences) v = std::abs(v - out.median_difference);
  out.sigma_of_median = 1.2533 * 1.4826 * median_of(differences) / std::sqrt(n);
  out.z = out.sigma_of_median > 0 ? out.median_difference / out.sigma_of_median : 0.0;
  out.significant = std::abs(out.z) > threshold_sigma;
  return out;
}

files::FloatImage difference_maps(const SessionDifference& d) {
  files::FloatImage maps;
  maps.width = d.width, maps.height = d.height;
  maps.channel_names = {"difference", "sigma_difference", "z", "significant"};
  std::vector<float> significant(d.significant.begin(), d.significant.end());
  maps.channels = {d.difference, d.sigma, d.z, significant};
  return maps;
}

}  // namespace chromo::maps
