#include "tiled_tiff_writer.hpp"

#include <libdeflate.h>
#include <tiffio.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

namespace chromo::maps::detail {

namespace {
constexpr int kTile = 256;

int bytes_of(SampleType type) { return type == SampleType::kUint8 ? 1 : type == SampleType::kUint16 ? 2 : 4; }
}  // namespace

struct TiledTiffWriter::Tiff {
  TIFF* handle = nullptr;
  ~Tiff() {
    if (handle) TIFFClose(handle);
  }
};

TiledTiffWriter::TiledTiffWriter(const std::filesystem::path& path, bool big_tiff, int zip_level, int threads)
    : tiff_(std::make_unique<Tiff>()), path_(path), zip_level_(std::clamp(zip_level, 1, 9)), threads_(threads) {
  if (threads_ <= 0) threads_ = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  tiff_->handle = TIFFOpen(path.c_str(), big_tiff ? "w8l" : "wl");
  if (!tiff_->handle) throw std::runtime_error("libtiff could not create " + path.string());
}

TiledTiffWriter::~TiledTiffWriter() = default;

void TiledTiffWriter::add_page(const void* samples, int width, int height, SampleType type,
                               const std::string& description) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("TIFF page of " + std::to_string(width) + "x" +
                                                             std::to_string(height) + " pixels");
  TIFF* tif = tiff_->handle;
  const int bytes = bytes_of(type);
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(width));
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(height));
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, static_cast<std::uint16_t>(8 * bytes));
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, static_cast<std::uint16_t>(1));
  TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, type == SampleType::kFloat32 ? SAMPLEFORMAT_IEEEFP : SAMPLEFORMAT_UINT);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE);
  TIFFSetField(tif, TIFFTAG_TILEWIDTH, static_cast<std::uint32_t>(kTile));
  TIFFSetField(tif, TIFFTAG_TILELENGTH, static_cast<std::uint32_t>(kTile));
  TIFFSetField(tif, TIFFTAG_SOFTWARE, "chromosphere");
  if (first_page_ && !description.empty()) TIFFSetField(tif, TIFFTAG_IMAGEDESCRIPTION, description.c_str());
  first_page_ = false;

  const int across = (width + kTile - 1) / kTile, down = (height + kTile - 1) / kTile;
  const int tiles = across * down;
  const std::size_t tile_bytes = static_cast<std::size_t>(kTile) * kTile * bytes;
  const auto* source = static_cast<const std::uint8_t*>(samples);
  std::vector<std::vector<std::uint8_t>> compressed(tiles);
  std::vector<int> failed(tiles, 0);
#pragma omp parallel num_threads(threads_)
  {
    std::vector<std::uint8_t> tile(tile_bytes);
    // libdeflate: zlib-format streams (what TIFF's Adobe Deflate holds), about
    // twice zlib's speed at the same level.
    std::unique_ptr<libdeflate_compressor, void (*)(libdeflate_compressor*)> compressor(
        libdeflate_alloc_compressor(zip_level_), libdeflate_free_compressor);
#pragma omp for schedule(dynamic)
    for (int t = 0; t < tiles; ++t) {
      const int x0 = (t % across) * kTile, y0 = (t / across) * kTile;
      const int w = std::min(kTile, width - x0), h = std::min(kTile, height - y0);
      std::fill(tile.begin(), tile.end(), 0);  // edge tiles are padded with zeros
      for (int y = 0; y < h; ++y)
        std::memcpy(tile.data() + static_cast<std::size_t>(y) * kTile * bytes,
                    source + (static_cast<std::size_t>(y0 + y) * width + x0) * bytes, static_cast<std::size_t>(w) * bytes);
      std::size_t size = 0;
      if (compressor) {
        compressed[t].resize(libdeflate_zlib_compress_bound(compressor.get(), tile_bytes));
        size = libdeflate_zlib_compress(compressor.get(), tile.data(), tile_bytes, compressed[t].data(),
                                        compressed[t].size());
      }
      if (size == 0) failed[t] = 1;
      compressed[t].resize(size);
    }
  }
  for (int t = 0; t < tiles; ++t) {
    if (failed[t]) throw std::runtime_error("libdeflate could not compress tile " + std::to_string(t) + " of " + path_.string());
    if (TIFFWriteRawTile(tif, static_cast<std::uint32_t>(t), compressed[t].data(),
                         static_cast<tmsize_t>(compressed[t].size())) < 0)
      throw std::runtime_error("libtiff could not write tile " + std::to_string(t) + " of " + path_.string() +
                               " (disk full?)");
    std::vector<std::uint8_t>().swap(compressed[t]);
  }
  if (!TIFFWriteDirectory(tif)) throw std::runtime_error("libtiff could not write a page of " + path_.string());
}

void TiledTiffWriter::finish() {
  TIFF* tif = tiff_->handle;
  tiff_->handle = nullptr;
  if (!tif) return;
  const bool flushed = TIFFFlush(tif) == 1;
  TIFFClose(tif);
  if (!flushed) throw std::runtime_error("libtiff could not flush " + path_.string());
}

}  // namespace chromo::maps::detail
