#pragma once
// Float images as OpenEXR files: read any channels (half or float) as float,
// write FLOAT channels. The one image format every library shares: session
// derived data, measurement files, map files. Errors throw ImageError naming
// the file. Thread rules: free functions, reentrant.

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>
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
  // String attributes of the header whose names start with "chromo." (e.g.
  // maps.exr's "chromo.discrepancy_basis"): read_exr reads them, write_exr
  // writes them; other attributes are neither read nor written.
  std::vector<std::pair<std::string, std::string>> attributes{};
  const std::vector<float>& channel(const std::string& name) const;  // ImageError if absent
  const std::string* attribute(const std::string& name) const;       // nullptr if absent
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

// An OpenEXR file's size and channel names without its pixels (after
// check_exr_file): what a listing of a folder's images needs. ImageError
// naming the file otherwise.
struct ExrHeader {
  int width = 0, height = 0;
  std::vector<std::string> channel_names;
};
ExrHeader read_exr_header(const std::filesystem::path& path);

// How write_exr compresses. Always ZIP (deflate per 16 scanlines, lossless:
// docs/formats/session.md); the blocks are compressed on `threads` threads
// (OpenEXR's global pool, grown to the most any write asked for; 0 = all
// cores, 1 = the caller's thread alone). zip_level: deflate's 0-9, -1 =
// OpenEXR's default (4): the same format, any reader reads every level.
struct ExrWriteOptions {
  int threads = 0;
  int zip_level = -1;
};
// Threads a write with `threads` uses (0 → the machine's cores);
// std::invalid_argument below 0.
int exr_writer_threads(int threads);
void write_exr(const std::filesystem::path& path, const FloatImage& image, const ExrWriteOptions& options = {});

}  // namespace chromo::files
