#pragma once
// Float images as OpenEXR files: read any channels (half or float) as float,
// write FLOAT channels. The one image format every library shares: session
// derived data, measurement files, map files. Errors throw ImageError naming
// the file. Thread rules: free functions, reentrant.

#include <cstdint>
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

// Checks an OpenEXR file before any library reads it: a regular file within
// kMaxImageFileBytes, a single-part, non-deep version 2 header (read by hand,
// at most 1 MiB) whose data window is within kMaxImagePixels
// (bounded_read.hpp), a lossless compression (DWAA/DWAB are refused), and
// whose declared pixel bytes are at most 1376 times the file's size (the
// densest any lossless OpenEXR compression packs: a truncated or forged file
// is refused before any pixel memory is allocated). Returns the data window's size; ImageError naming the
// file and the problem otherwise. read_exr calls it first.
struct ExrSize {
  std::int64_t width = 0, height = 0;
};
ExrSize check_exr_file(const std::filesystem::path& path);

FloatImage read_exr(const std::filesystem::path& path);
void write_exr(const std::filesystem::path& path, const FloatImage& image);

}  // namespace chromo::files
