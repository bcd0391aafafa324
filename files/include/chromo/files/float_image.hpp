#pragma once
// Float images as OpenEXR files: read any channels (half or float) as float,
// write FLOAT channels. The one image format every library shares: session
// derived data, measurement files, map files. Errors throw ImageError naming
// the file. Thread rules: free functions, reentrant.

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace chromo::files {

class ImageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct FloatImage {
  int width = 0, height = 0;
  std::vector<std::string> channel_names;
  std::vector<std::vector<float>> channels;  // width × height each, row-major
  const std::vector<float>& channel(const std::string& name) const;  // ImageError if absent
};

FloatImage read_exr(const std::filesystem::path& path);
void write_exr(const std::filesystem::path& path, const FloatImage& image);

}  // namespace chromo::files
