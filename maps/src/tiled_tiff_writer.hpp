#pragma once
// A multi-page tiled TIFF writer for the OME-TIFF files (ome_tiff.hpp): each
// page one plane of 8/16-bit unsigned or 32-bit float samples, 256 × 256
// tiles, Deflate (zlib format, by libdeflate) without predictor, little-endian.
// The tiles of a page are compressed on several threads (OpenMP) and written in order as raw
// tiles through libtiff. The first page carries the ImageDescription given.
// Errors: std::runtime_error naming the file.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace chromo::maps::detail {

enum class SampleType { kUint8, kUint16, kFloat32 };

class TiledTiffWriter {
 public:
  // big_tiff: BigTIFF (64-bit offsets), for files that may pass 4 GB.
  TiledTiffWriter(const std::filesystem::path& path, bool big_tiff, int zip_level, int threads);
  ~TiledTiffWriter();
  TiledTiffWriter(const TiledTiffWriter&) = delete;
  TiledTiffWriter& operator=(const TiledTiffWriter&) = delete;

  // `samples`: width × height samples of `type`, row-major, host order.
  void add_page(const void* samples, int width, int height, SampleType type, const std::string& description);
  // Flushes and closes; the destructor closes without checking.
  void finish();

 private:
  struct Tiff;
  std::unique_ptr<Tiff> tiff_;
  std::filesystem::path path_;
  int zip_level_, threads_;
  bool first_page_ = true;
};

}  // namespace chromo::maps::detail
