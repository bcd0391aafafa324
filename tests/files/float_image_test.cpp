// OpenEXR float images (files/float_image.hpp).
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>

#include <vector>

#include <gtest/gtest.h>

#include "../support/fresh_directory.hpp"
#include "chromo/files/float_image.hpp"

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

}  // namespace
}  // namespace chromo::files
