#include "chromo/session/frame_files.hpp"
#include "chromo/files/bounded_read.hpp"

#include <tiffio.h>

#include "chromo/files/float_image.hpp"


#include <memory>
#include <stdexcept>

namespace chromo::session {

namespace {
struct TiffCloser {
  void operator()(TIFF* tiff) const {
    if (tiff) TIFFClose(tiff);
  }
};
using TiffPtr = std::unique_ptr<TIFF, TiffCloser>;
}  // namespace

void write_frame_tiff(const std::filesystem::path& path, const FrameRecord& record,
                      std::span<const std::uint8_t> samples, files::StorageBudget* budget) {
  write_frame_tiff(path, record, to_json(record), samples, budget);
}

void write_frame_tiff(const std::filesystem::path& path, const FrameRecord& record, const nlohmann::json& record_json,
                      std::span<const std::uint8_t> samples, files::StorageBudget* budget) {
  const auto& format = drivers::pixel_format_info(record.pixel_format);
  const int bits = format.significant_bits;
  const int container_bits = 8 * format.bytes_per_sample;
  const int samples_per_pixel = format.samples_per_pixel;
  const std::size_t row_bytes = format.frame_bytes(record.width, 1);
  if (record.width <= 0 || record.height <= 0 || samples.size() != format.frame_bytes(record.width, record.height))
    throw std::invalid_argument("frame " + std::to_string(record.sequence) + ": " + std::to_string(samples.size()) +
                                " bytes do not make a " + std::to_string(record.width) + "x" +
                                std::to_string(record.height) + " " + std::string(format.name) + " image");
  const std::string description = record_json.dump();
  files::commit_file_durably(path, budget, [&](const std::filesystem::path& temporary) {
    TiffPtr tiff(TIFFOpen(temporary.c_str(), "w"));
    if (!tiff) throw std::runtime_error("libtiff could not create " + temporary.string());
    TIFFSetField(tiff.get(), TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(record.width));
    TIFFSetField(tiff.get(), TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(record.height));
    TIFFSetField(tiff.get(), TIFFTAG_BITSPERSAMPLE, static_cast<std::uint16_t>(container_bits));
    TIFFSetField(tiff.get(), TIFFTAG_SAMPLESPERPIXEL, static_cast<std::uint16_t>(samples_per_pixel));
    TIFFSetField(tiff.get(), TIFFTAG_PHOTOMETRIC, samples_per_pixel == 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK);
    TIFFSetField(tiff.get(), TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(tiff.get(), TIFFTAG_COMPRESSION, COMPRESSION_NONE);
    TIFFSetField(tiff.get(), TIFFTAG_ROWSPERSTRIP, static_cast<std::uint32_t>(std::max<std::size_t>(1, 65536 / row_bytes)));
    if (bits == 12) TIFFSetField(tiff.get(), TIFFTAG_MAXSAMPLEVALUE, static_cast<std::uint16_t>(4095));
    TIFFSetField(tiff.get(), TIFFTAG_IMAGEDESCRIPTION, description.c_str());
    TIFFSetField(tiff.get(), TIFFTAG_SOFTWARE, "chromod");
    for (int row = 0; row < record.height; ++row) {
      auto* line = const_cast<std::uint8_t*>(samples.data() + row_bytes * static_cast<std::size_t>(row));
      if (TIFFWriteScanline(tiff.get(), line, static_cast<std::uint32_t>(row), 0) < 0)
        throw files::StorageFullError("libtiff could not write row " + std::to_string(row) + " of " + temporary.string() +
                               " (disk full?)");
    }
    if (!TIFFFlush(tiff.get())) throw files::StorageFullError("libtiff could not flush " + temporary.string());
  });
}

TiffImage read_tiff(const std::filesystem::path& path) {
  // A regular file within the image cap before libtiff opens it (a FIFO would
  // block, a device never end); "m": no memory map, so a file truncated while
  // it is read is a read error, not SIGBUS.
  files::check_regular_file(path, files::kMaxImageFileBytes, "TIFF");
  TiffPtr tiff(TIFFOpen(path.c_str(), "rm"));
  if (!tiff) throw std::runtime_error("not a readable TIFF: " + path.string());
  TiffImage image;
  std::uint32_t width = 0, height = 0;
  std::uint16_t bits = 0, samples = 1;
  TIFFGetField(tiff.get(), TIFFTAG_IMAGEWIDTH, &width);
  TIFFGetField(tiff.get(), TIFFTAG_IMAGELENGTH, &height);
  TIFFGetField(tiff.get(), TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_SAMPLESPERPIXEL, &samples);
  char* description = nullptr;
  if (TIFFGetField(tiff.get(), TIFFTAG_IMAGEDESCRIPTION, &description) && description) image.description = description;
  // Checked from the header before any pixel memory is allocated.
  files::check_image_size(path, width, height);
  if (bits != 8 && bits != 16 && bits != 32)
    throw files::InputFileError(path.string() + ": " + std::to_string(bits) + " bits per sample (8, 16 or 32 expected)");
  if (samples < 1 || samples > 4)
    throw files::InputFileError(path.string() + ": " + std::to_string(samples) + " samples per pixel (1 to 4 expected)");
  image.width = static_cast<int>(width);
  image.height = static_cast<int>(height);
  image.bits_per_sample = bits;
  image.samples_per_pixel = samples;
  const auto scanline = static_cast<std::size_t>(TIFFScanlineSize(tiff.get()));
  if (scanline != static_cast<std::size_t>(width) * samples * (bits / 8))
    throw files::InputFileError(path.string() + ": scanline of " + std::to_string(scanline) + " bytes for " +
                                std::to_string(width) + " pixels of " + std::to_string(samples) + "×" +
                                std::to_string(bits) + " bits (planar or compressed-odd layouts are not read)");
  image.data.resize(scanline * height);
  for (std::uint32_t row = 0; row < height; ++row)
    if (TIFFReadScanline(tiff.get(), image.data.data() + scanline * row, row, 0) < 0)
      throw std::runtime_error("TIFF row " + std::to_string(row) + " unreadable in " + path.string());
  return image;
}

void write_float_exr(const std::filesystem::path& path, int width, int height,
                     std::vector<FloatChannel> channels, files::StorageBudget* budget,
                     const files::ExrWriteOptions& exr) {
  const auto pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  for (const auto& channel : channels)
    if (channel.values.size() != pixels)
      throw std::invalid_argument("EXR channel " + channel.name + ": " + std::to_string(channel.values.size()) +
                                  " values for " + std::to_string(pixels) + " pixels");
  // files::write_exr writes FLOAT channels, ZIP compressed; here it fills
  // the temporary file of the durable commit.
  files::FloatImage image;
  image.width = width;
  image.height = height;
  for (auto& channel : channels) {
    image.channel_names.push_back(std::move(channel.name));
    image.channels.push_back(std::move(channel.values));
  }
  files::commit_file_durably(path, budget,
                      [&](const std::filesystem::path& temporary) { files::write_exr(temporary, image, exr); });
}

}  // namespace chromo::session
