#pragma once
// Image files of the session folder, each written crash-safe through
// commit_file_durably():
//  - raw frames as TIFF (libtiff, uncompressed, one strip per row block) at
//    their native bit depth: 8-bit formats as 8-bit samples, 12- and 16-bit
//    formats as 16-bit samples (12-bit values unscaled, MaxSampleValue 4095);
//    Bayer frames as one-sample greyscale plus the CFA pattern in the
//    ImageDescription JSON; RGB8 as three samples.
//  - derived float data as OpenEXR (FLOAT channels, ZIP compression).
// read_tiff() exists for tests and tools (any file written here reads back).

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/files/durable_file.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/session/frame_record.hpp"

namespace chromo::session {

// Writes a complete frame: `samples` as the camera sent them (pixel-format
// facts from drivers' table), the record's journal JSON in ImageDescription.
// Throws std::invalid_argument when samples.size() does not match the record's
// geometry and format.
void write_frame_tiff(const std::filesystem::path& path, const FrameRecord& record,
                      std::span<const std::uint8_t> samples, files::StorageBudget* budget);
// The same with the record's journal JSON already made (to_json(record)), so
// a caller that also journals the record builds it once.
void write_frame_tiff(const std::filesystem::path& path, const FrameRecord& record, const nlohmann::json& record_json,
                      std::span<const std::uint8_t> samples, files::StorageBudget* budget);

struct TiffImage {
  int width = 0, height = 0, samples_per_pixel = 0, bits_per_sample = 0;
  std::vector<std::uint8_t> data;  // rows as stored (16-bit samples in host order)
  std::string description;
};
TiffImage read_tiff(const std::filesystem::path& path);

struct FloatChannel {
  std::string name;
  std::vector<float> values;  // width × height, row-major
};
// exr: the ZIP blocks' threads and level (files/float_image.hpp).
void write_float_exr(const std::filesystem::path& path, int width, int height,
                     std::vector<FloatChannel> channels, files::StorageBudget* budget,
                     const files::ExrWriteOptions& exr = {});

}  // namespace chromo::session
