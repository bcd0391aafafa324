// A study's region masks (study_regions.hpp).
#include "study_regions.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <set>
#include <stdexcept>

#include "chromo/files/bounded_read.hpp"

namespace chromo::cli::study {

namespace fs = std::filesystem;

std::vector<RegionSpec> parse_regions(const std::vector<std::string>& options) {
  std::vector<RegionSpec> regions;
  for (const std::string& option : options) {
    const auto equals = option.find('=');
    const std::string name = option.substr(0, equals);
    const bool name_ok = !name.empty() && name.size() <= 32 && std::all_of(name.begin(), name.end(), [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    });
    if (equals == std::string::npos || equals + 1 == option.size() || !name_ok)
      throw std::invalid_argument("--region: \"" + option +
                                  "\" is not NAME=PATH (NAME: 1-32 of A-Z a-z 0-9 _ -; PATH: a PNG mask per session)");
    if (std::any_of(regions.begin(), regions.end(), [&](const RegionSpec& r) { return r.name == name; }))
      throw std::invalid_argument("--region: the region \"" + name + "\" is given twice");
    regions.push_back({name, option.substr(equals + 1)});
  }
  return regions;
}

std::vector<std::string> region_options(const std::vector<RegionSpec>& regions) {
  std::vector<std::string> out;
  for (const auto& region : regions) out.push_back(region.name + "=" + region.path);
  return out;
}

fs::path region_mask_file(const fs::path& session_folder, const RegionSpec& region, const std::string& camera) {
  std::string path = region.path;
  for (auto at = path.find("{camera}"); at != std::string::npos; at = path.find("{camera}", at + camera.size()))
    path.replace(at, 8, camera);
  const fs::path file(path);
  return file.is_absolute() ? file : session_folder / file;
}

std::vector<fs::path> region_input_files(const fs::path& session_folder, const RegionSpec& region) {
  std::set<std::string> cameras;  // frames/<step>/<camera>-<sequence>.tiff
  std::error_code error;
  for (auto it = fs::recursive_directory_iterator(session_folder / "frames", error); !error && it != fs::end(it);
       it.increment(error)) {
    const std::string name = it->path().filename().string();
    if (const auto dash = name.rfind('-'); dash != std::string::npos && it->is_regular_file(error))
      cameras.insert(name.substr(0, dash));
  }
  std::vector<fs::path> files;
  for (const std::string& camera : cameras) {
    const fs::path file = region_mask_file(session_folder, region, camera);
    if (fs::exists(file, error) && std::find(files.begin(), files.end(), file) == files.end()) files.push_back(file);
  }
  return files;
}

std::vector<std::uint8_t> read_region_mask(const fs::path& file, int width, int height) {
  cv::Mat mask;
  try {
    const std::string bytes = files::read_png_file(file);
    mask = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data())),
                        cv::IMREAD_GRAYSCALE);
  } catch (const std::exception& e) {
    throw std::invalid_argument("region mask " + file.string() + ": " + e.what());
  }
  if (mask.empty()) throw std::invalid_argument("region mask " + file.string() + ": not a readable PNG");
  if (mask.cols != width || mask.rows != height)
    throw std::invalid_argument("region mask " + file.string() + ": " + std::to_string(mask.cols) + "×" +
                                std::to_string(mask.rows) + ", the maps are " + std::to_string(width) + "×" +
                                std::to_string(height));
  return std::vector<std::uint8_t>(mask.begin<std::uint8_t>(), mask.end<std::uint8_t>());
}

}  // namespace chromo::cli::study
