#include "maps_files.hpp"

#include <stdexcept>
#include <vector>

namespace chromo::cli {

namespace fs = std::filesystem;

fs::path maps_file_of(const fs::path& input, const std::string& camera) {
  if (fs::is_regular_file(input)) return input;
  if (!fs::is_directory(input)) throw std::invalid_argument(input.string() + ": no such file or folder");
  const std::vector<fs::path> candidates =
      camera.empty() ? std::vector<fs::path>{input / "maps.exr", input / "results" / "maps.exr"}
                     : std::vector<fs::path>{input / "results" / camera / "maps.exr", input / camera / "maps.exr"};
  for (const fs::path& file : candidates)
    if (fs::is_regular_file(file)) return file;
  throw std::invalid_argument(input.string() + ": no maps.exr " +
                              (camera.empty() ? "in it or its results/ (give --camera NAME for results/NAME/)"
                                              : "in results/" + camera + "/"));
}

files::FloatImage read_maps_of(const fs::path& input, const std::string& camera, const std::string& what) {
  const fs::path file = maps_file_of(input, camera);
  try {
    return files::read_exr(file);
  } catch (const files::ImageError& e) {
    throw std::invalid_argument(what + ": " + e.what());
  }
}

}  // namespace chromo::cli
