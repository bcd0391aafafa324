#include "chromo/maps/profile_table.hpp"

#include <omp.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "chromo/files/float_image.hpp"
#include "chromo/estimation/skin_parameters.hpp"

namespace chromo::maps {
namespace {

std::vector<double> log_spaced(double lo, double hi, int n) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(lo * std::pow(hi / lo, static_cast<double>(i) / (n - 1)));
  return v;
}

bool check_axis(const std::vector<double>& axis, const estimation::ParameterRange& range, std::string* error) {
  if (axis.empty()) {
    *error = std::string(range.name) + " axis is empty";
    return false;
  }
  for (std::size_t i = 0; i < axis.size(); ++i) {
    if (!std::isfinite(axis[i]) || !range.contains(axis[i])) {
      *error = std::string(range.name) + " axis value " + std::to_string(axis[i]) + " is outside " +
               std::to_string(range.min) + "-" + std::to_string(range.max);
      return false;
    }
    if (i > 0 && !(axis[i] > axis[i - 1])) {
      *error = std::string(range.name) + " axis must increase strictly";
      return false;
    }
  }
  return true;
}

// Index of the value nearest to x on a sorted axis, comparing f(values).
template <typename Transform>
std::size_t nearest(const std::vector<double>& axis, double x, Transform f) {
  std::size_t best = 0;
  double best_distance = std::abs(f(axis[0]) - f(x));
  for (std::size_t i = 1; i < axis.size(); ++i) {
    const double distance = std::abs(f(axis[i]) - f(x));
    if (distance < best_distance) best = i, best_distance = distance;
  }
  return best;
}


}  // namespace

ProfileTableAxes ProfileTableAxes::Default() {
  return {log_spaced(0.002, 0.5, 8), log_spaced(0.002, 0.32, 8), {0.3, 0.7, 1.0}, {0.0, 0.03, 0.08}};
}

bool ProfileTableAxes::IsValid(std::string* error) const {
  std::string local;
  std::string* e = error ? error : &local;
  if (!check_axis(cm, estimation::kCmRange, e) || !check_axis(ch, estimation::kChRange, e) || !check_axis(bm, estimation::kBmRange, e) ||
      !check_axis(che, estimation::kCheRange, e))
    return false;
  if (entry_count() > 100000) {
    *e = "table of " + std::to_string(entry_count()) + " profiles is larger than 100000";
    return false;
  }
  return true;
}

ProfileTable build_profile_table(const RadialProfileModel& model, const ProfileTableAxes& axes,
                                 const std::string& illuminant_name, int threads, const files::Progress& progress) {
  std::string error;
  if (!axes.IsValid(&error)) throw std::invalid_argument("profile table axes: " + error);
  ProfileTable table;
  table.illuminant = illuminant_name;
  table.axes = axes;
  table.radius_mm = model.radii_mm();
  const std::size_t radii = table.radius_mm.size();
  const std::size_t entries = axes.entry_count();
  table.profiles_rgb_per_mm2.resize(entries * radii * 3);
  table.albedo_rgb.resize(entries * 3);
  std::vector<double> integral_error(entries, 0.0);

  std::atomic<std::size_t> done{0};
  std::atomic<bool> cancelled{false};
  const int thread_count = threads > 0 ? threads : omp_get_num_procs();
#pragma omp parallel for num_threads(thread_count) schedule(dynamic)
  for (std::ptrdiff_t e = 0; e < static_cast<std::ptrdiff_t>(entries); ++e) {
    if (cancelled.load()) continue;
    std::size_t rest = static_cast<std::size_t>(e);
    const std::size_t i_che = rest % axes.che.size();
    rest /= axes.che.size();
    const std::size_t i_bm = rest % axes.bm.size();
    rest /= axes.bm.size();
    const std::size_t i_ch = rest % axes.ch.size();
    const std::size_t i_cm = rest / axes.ch.size();
    const RadialProfile p = model.profile({axes.cm[i_cm], axes.ch[i_ch], axes.bm[i_bm], axes.che[i_che]});
    float* out = &table.profiles_rgb_per_mm2[static_cast<std::size_t>(e) * radii * 3];
    for (std::size_t r = 0; r < radii; ++r)
      for (int c = 0; c < 3; ++c) out[r * 3 + c] = static_cast<float>(p.rgb_per_mm2(static_cast<Eigen::Index>(r), c));
    for (int c = 0; c < 3; ++c) {
      table.albedo_rgb[static_cast<std::size_t>(e) * 3 + c] = static_cast<float>(p.albedo_rgb[c]);
      integral_error[e] = std::max(integral_error[e], std::abs(p.plane_integral_rgb[c] / p.albedo_rgb[c] - 1.0));
    }
    const std::size_t finished = ++done;
    if (omp_get_thread_num() == 0) {  // the calling thread: never concurrently
      progress.report(static_cast<double>(finished) / static_cast<double>(entries), "profile table");
      if (progress.cancelled()) cancelled = true;
    }
  }
  if (cancelled.load()) throw files::Cancelled{};
  progress.report(1.0, "profile table");
  table.worst_plane_integral_error = *std::max_element(integral_error.begin(), integral_error.end());
  return table;
}

void write_profile_table(files::OutputBatch& files, const ProfileTable& table) {
  nlohmann::ordered_json header;
  header["format"] = "chromosphere-radial-profiles";
  header["version"] = 1;
  header["illuminant"] = table.illuminant;
  header["colour_space"] = "linear sRGB (IEC 61966-2-1 primaries, D65 white; Bradford from the illuminant)";
  header["units"] = "reflectance per mm^2 (profile), dimensionless (albedo)";
  header["radius_mm"] = table.radius_mm;
  header["axes"] = {{"Cm", table.axes.cm}, {"Ch", table.axes.ch}, {"Bm", table.axes.bm}, {"Che", table.axes.che}};
  header["entry_order"] = "entry = ((i_Cm * n_Ch + i_Ch) * n_Bm + i_Bm) * n_Che + i_Che";
  header["data_file"] = "profiles.f32";
  header["data_layout"] = "float32 little-endian [entry][radius][R,G,B]";
  header["entries"] = table.axes.entry_count();
  header["albedo_rgb"] = table.albedo_rgb;
  header["worst_plane_integral_error"] = table.worst_plane_integral_error;
  {
    const std::filesystem::path path = files.temporary("profiles.f32");
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(table.profiles_rgb_per_mm2.data()),
              static_cast<std::streamsize>(table.profiles_rgb_per_mm2.size() * sizeof(float)));
    if (!out.flush()) throw std::runtime_error(path.string() + ": write failed");
  }
  files.write_text("profiles.json", header.dump(1) + "\n");
}

ParameterMaps read_parameter_maps(const std::filesystem::path& maps_exr) {
  if (!std::filesystem::exists(maps_exr)) throw std::runtime_error(maps_exr.string() + ": no such file");
  const files::FloatImage image = files::read_exr(maps_exr);
  auto channel = [&](const char* name) {
    try {
      return image.channel(name);
    } catch (const files::ImageError&) {
      throw std::runtime_error(maps_exr.string() + ": no channel '" + name + "' (expected Cm, Ch, Bm, Che, flags)");
    }
  };
  ParameterMaps maps{image.width, image.height, channel("Cm"), channel("Ch"), channel("Bm"), channel("Che"), channel("flags")};
  try {
    maps.discrepancy = read_discrepancy_layer(image, maps_exr.string());
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  return maps;
}

std::vector<std::uint32_t> nearest_entry_indices(const ProfileTable& table, const ParameterMaps& maps) {
  const std::size_t pixels = maps.cm.size();
  std::vector<std::uint32_t> indices(pixels, kNoProfileEntry);
  auto log = [](double v) { return std::log(v); };
  auto same = [](double v) { return v; };
  for (std::size_t i = 0; i < pixels; ++i) {
    const float values[] = {maps.cm[i], maps.ch[i], maps.bm[i], maps.che[i]};
    if (maps.flags[i] != 0.0f || !std::all_of(std::begin(values), std::end(values), [](float v) { return std::isfinite(v); }))
      continue;
    if (maps.cm[i] <= 0.0f || maps.ch[i] <= 0.0f) continue;
    indices[i] = static_cast<std::uint32_t>(table.entry_index(
        nearest(table.axes.cm, maps.cm[i], log), nearest(table.axes.ch, maps.ch[i], log),
        nearest(table.axes.bm, maps.bm[i], same), nearest(table.axes.che, maps.che[i], same)));
  }
  return indices;
}

void write_index_map(files::OutputBatch& files, const ParameterMaps& maps, const std::vector<std::uint32_t>& indices) {
  if (indices.size() != static_cast<std::size_t>(maps.width) * maps.height)
    throw std::invalid_argument("index map size does not match the maps");
  {
    const std::string path = files.temporary("index.exr").string();
    Imf::Header header(maps.width, maps.height);
    header.channels().insert("entry", Imf::Channel(Imf::UINT));
    Imf::OutputFile file(path.c_str(), header);
    Imf::FrameBuffer frame;
    frame.insert("entry", Imf::Slice(Imf::UINT, const_cast<char*>(reinterpret_cast<const char*>(indices.data())),
                                     sizeof(std::uint32_t), sizeof(std::uint32_t) * maps.width));
    file.setFrameBuffer(frame);
    file.writePixels(maps.height);
  }
}

}  // namespace chromo::maps
