#include "chromo/maps/photograph_files.hpp"

#include <algorithm>
#include <stdexcept>

#include "chromo/files/float_image.hpp"

namespace chromo::maps {

namespace fs = std::filesystem;

std::vector<PhotographFile> list_photograph_files(const fs::path& folder, int maps_width, int maps_height,
                                                  std::size_t max_entries) {
  std::error_code error;
  if (!fs::is_directory(fs::symlink_status(folder, error)))
    throw std::invalid_argument(folder.string() + ": not a folder");
  std::vector<PhotographFile> found;
  std::size_t entries = 0;
  // Default options: directory symbolic links are not followed.
  for (auto it = fs::recursive_directory_iterator(folder, fs::directory_options::skip_permission_denied, error);
       !error && it != fs::recursive_directory_iterator() && entries < max_entries; it.increment(error), ++entries) {
    const fs::path& path = it->path();
    const std::string name = path.filename().string();
    if (name.starts_with(".")) {
      if (it->is_directory(error)) it.disable_recursion_pending();
      continue;
    }
    if (it->is_symlink(error) || !it->is_regular_file(error) || path.extension() != ".exr") continue;
    try {
      const files::ExrHeader header = files::read_exr_header(path);
      const auto has = [&](const char* c) {
        return std::find(header.channel_names.begin(), header.channel_names.end(), c) != header.channel_names.end();
      };
      if (!has("R") || !has("G") || !has("B")) continue;
      found.push_back({path.lexically_relative(folder).generic_string(), header.width, header.height,
                       header.width == maps_width && header.height == maps_height});
    } catch (const files::ImageError&) {
      // not an image Relight could read: not offered
    }
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.file < b.file; });
  return found;
}

}  // namespace chromo::maps
