// OpenEXR float images (files/float_image.hpp).
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>

#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "../support/fresh_directory.hpp"
#include "chromo/files/float_image.hpp"

using ::testing::HasSubstr;

namespace chromo::files {
namespace {

TEST(FloatImage, WritesAndReadsBackEveryChannel) {
  const auto dir = testing::fresh_directory("float-image");
  const FloatImage written{3, 2, {"A", "B"}, {{1, 2, 3, 4, 5, 6}, {-1, -2, -3, -4, -5, -6}}};
  write_exr(dir / "a.exr", written);
  const FloatImage read = read_exr(dir / "a.exr");
  EXPECT_EQ(read.width, 3);
  EXPECT_EQ(read.height, 2);
  EXPECT_EQ(read.channel("A"), written.channels[0]);
  EXPECT_EQ(read.channel("B"), written.channels[1]);
  EXPECT_THROW(read.channel("C"), ImageError);
  std::filesystem::remove_all(dir);
}

// Threads and ZIP level change how the blocks are compressed, never the
// pixels: every setting reads back the same floats (noise, NaN and ±∞
// included), and a lower level is a valid ZIP file any reader opens.
TEST(FloatImage, EveryThreadCountAndZipLevelWritesTheSamePixels) {
  const auto dir = testing::fresh_directory("float-image-threads");
  FloatImage written{301, 97, {"Y", "Z"}, {std::vector<float>(301 * 97), std::vector<float>(301 * 97)}};
  std::uint32_t seed = 7;
  for (std::size_t i = 0; i < written.channels[0].size(); ++i) {
    seed = seed * 1664525u + 1013904223u;
    written.channels[0][i] = static_cast<float>(seed >> 8) / 16777216.0f;
    written.channels[1][i] = static_cast<float>(i % 301) * 0.25f;
  }
  written.channels[0][5] = std::numeric_limits<float>::quiet_NaN();
  written.channels[1][6] = std::numeric_limits<float>::infinity();
  int file = 0;
  for (const ExrWriteOptions options : {ExrWriteOptions{1, -1}, ExrWriteOptions{2, -1}, ExrWriteOptions{0, 1},
                                        ExrWriteOptions{3, 9}, ExrWriteOptions{1, 0}}) {
    const auto path = dir / ("f" + std::to_string(file++) + ".exr");
    write_exr(path, written, options);
    const FloatImage read = read_exr(path);
    for (std::size_t c = 0; c < 2; ++c)
      ASSERT_EQ(0, std::memcmp(read.channels[c].data(), written.channels[c].data(), read.channels[c].size() * 4))
          << options.threads << " " << options.zip_level;
  }
  // Level 1 compresses the smooth channel less tightly than level 9, but compresses it.
  EXPECT_LT(std::filesystem::file_size(dir / "f3.exr"), std::filesystem::file_size(dir / "f2.exr") + 1);
  EXPECT_LT(std::filesystem::file_size(dir / "f2.exr"), 2u * 301u * 97u * 4u);
  EXPECT_THROW(write_exr(dir / "bad.exr", written, {-1, -1}), std::invalid_argument);
  EXPECT_THROW(write_exr(dir / "bad.exr", written, {1, 10}), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.exr"));
  EXPECT_EQ(exr_writer_threads(3), 3);
  EXPECT_GE(exr_writer_threads(0), 1);
  std::filesystem::remove_all(dir);
}

// fuzz_exr found it (tests/fuzz/corpus/fuzz_exr/regression-window-far-from-origin.exr):
// a data window whose origin is far from (0, 0) made the buffer's base
// pointer overflow an int. Such a window is legal OpenEXR and reads whole.
TEST(FloatImage, ADataWindowFarFromTheOriginReads) {
  const auto dir = testing::fresh_directory("float-image-window");
  const Imath::Box2i window({-5, -84215046}, {-2, -84215044});  // 4 × 3 pixels
  Imf::Header header(Imath::Box2i({0, 0}, {3, 2}), window);
  header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
  std::vector<float> values(12);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<float>(i) * 0.5f;
  {
    Imf::OutputFile file((dir / "far.exr").c_str(), header);
    Imf::FrameBuffer frame;
    frame.insert("Y", Imf::Slice::Make(Imf::FLOAT, values.data(), window));
    file.setFrameBuffer(frame);
    file.writePixels(3);
  }
  const FloatImage read = read_exr(dir / "far.exr");
  EXPECT_EQ(read.width, 4);
  EXPECT_EQ(read.height, 3);
  EXPECT_EQ(read.channel("Y"), values);
  std::filesystem::remove_all(dir);
}

std::string refusal(const std::filesystem::path& path) {
  try {
    read_exr(path);
  } catch (const ImageError& e) {
    return e.what();
  }
  return "(read without error)";
}

void write_constant(const std::filesystem::path& path, int width, int height, Imf::Compression compression,
                    Imf::PixelType type) {
  Imf::Header header(width, height);
  header.compression() = compression;
  header.channels().insert("Y", Imf::Channel(type));
  // All-zero bytes are 0.0 as FLOAT and as HALF: one buffer serves both.
  const std::size_t value_bytes = type == Imf::HALF ? 2 : 4;
  std::vector<char> zeros(static_cast<std::size_t>(width) * height * value_bytes, 0);
  Imf::OutputFile file(path.c_str(), header);
  Imf::FrameBuffer frame;
  frame.insert("Y", Imf::Slice(type, zeros.data(), value_bytes, value_bytes * width));
  file.setFrameBuffer(frame);
  file.writePixels(height);
}

// The expansion bound (1376 declared pixel bytes per file byte) must never
// refuse a real file: a constant image, the most compressible there is,
// reads back under every lossless compression and both pixel types.
TEST(FloatImage, ConstantImagesReadUnderEveryLosslessCompression) {
  const auto dir = testing::fresh_directory("float-image-constant");
  const std::vector<Imf::Compression> lossless = {Imf::NO_COMPRESSION,  Imf::RLE_COMPRESSION, Imf::ZIPS_COMPRESSION,
                                                  Imf::ZIP_COMPRESSION, Imf::PIZ_COMPRESSION, Imf::PXR24_COMPRESSION,
                                                  Imf::B44_COMPRESSION, Imf::B44A_COMPRESSION};
  for (const auto compression : lossless) {
    for (const auto type : {Imf::FLOAT, Imf::HALF}) {
      const auto path = dir / ("c" + std::to_string(compression) + "-" + std::to_string(type) + ".exr");
      write_constant(path, 2048, 1024, compression, type);
      const auto declared_bytes = 2048.0 * 1024 * (type == Imf::HALF ? 2 : 4);
      EXPECT_LT(declared_bytes / static_cast<double>(std::filesystem::file_size(path)), 1376.0) << path;
      const FloatImage image = read_exr(path);
      EXPECT_EQ(image.width, 2048) << path;
      EXPECT_EQ(image.channel("Y")[12345], 0.0f) << path;
    }
  }
  std::filesystem::remove_all(dir);
}

// fuzz_exr found it: a 297-byte file whose header declares a 16.3-MP row
// (ZIP) made the reader allocate and fill 65 MB before OpenEXR failed on the
// missing data (64 MP: 256 MB and 4 s here). Refused from the header now.
TEST(FloatImage, AFileTooSmallForItsDeclaredPixelsIsRefusedFromTheHeader) {
  const auto dir = testing::fresh_directory("float-image-forged");
  write_constant(dir / "real.exr", 4096, 4096, Imf::ZIP_COMPRESSION, Imf::FLOAT);
  std::string bytes;
  {
    std::ifstream in(dir / "real.exr", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto cut = bytes.size() / 4;
  std::ofstream(dir / "truncated.exr", std::ios::binary) << bytes.substr(0, cut);
  EXPECT_THAT(refusal(dir / "truncated.exr"),
              HasSubstr("truncated.exr: not a readable OpenEXR file: the header declares 67108864 bytes of pixels, "
                        "more than 1376 times the file's " + std::to_string(cut) + " bytes"));
  std::filesystem::remove_all(dir);
}

// fuzz_exr found it (corpus: regression-float-attribute-of-36-bytes.exr):
// OpenEXR reads a `float` attribute as 4 bytes whatever size the file
// declares, so a 36-byte one made its reading of the header part from the
// project's check, and it then took other bytes for an attribute size and
// allocated by them (30 s under ASan for a 477-byte file).
TEST(FloatImage, AnAttributeWhoseSizeDisagreesWithItsTypeIsRefused) {
  const auto dir = testing::fresh_directory("float-image-attribute");
  write_exr(dir / "a.exr", FloatImage{2, 2, {"Y"}, {{1, 2, 3, 4}}});
  std::string bytes;
  {
    std::ifstream in(dir / "a.exr", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string attribute("pixelAspectRatio\0float\0", 23);
  const auto at = bytes.find(attribute);
  ASSERT_NE(at, std::string::npos);
  bytes[at + attribute.size()] = 36;
  std::ofstream(dir / "forged.exr", std::ios::binary) << bytes;
  EXPECT_THAT(refusal(dir / "forged.exr"),
              HasSubstr("forged.exr: not a readable OpenEXR file: header attribute 'pixelAspectRatio' of type float has "
                        "size 36, not 4"));
  std::filesystem::remove_all(dir);
}

TEST(FloatImage, LossyDwaCompressionIsRefusedByName) {
  const auto dir = testing::fresh_directory("float-image-dwa");
  write_constant(dir / "dwa.exr", 64, 64, Imf::DWAA_COMPRESSION, Imf::HALF);
  EXPECT_THAT(refusal(dir / "dwa.exr"), HasSubstr("dwa.exr: not a readable OpenEXR file: DWAA/DWAB compression is lossy"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace chromo::files
