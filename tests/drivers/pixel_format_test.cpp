// The camera interface's one pixel-format table (drivers/camera.hpp).
#include <gtest/gtest.h>

#include "chromo/drivers/camera.hpp"

namespace chromo::drivers {
namespace {

TEST(PixelFormatTable, HoldsEachFormatsFacts) {
  struct Expected {
    PixelFormat format;
    const char* name;
    int bits, bytes, samples;
    ColourLayout layout;
    std::uint32_t full_scale;
  };
  const Expected expected[] = {
      {PixelFormat::kMono8, "Mono8", 8, 1, 1, ColourLayout::kMono, 255},
      {PixelFormat::kMono12, "Mono12", 12, 2, 1, ColourLayout::kMono, 4095},
      {PixelFormat::kMono16, "Mono16", 16, 2, 1, ColourLayout::kMono, 65535},
      {PixelFormat::kBayerRG8, "BayerRG8", 8, 1, 1, ColourLayout::kBayerRGGB, 255},
      {PixelFormat::kBayerRG12, "BayerRG12", 12, 2, 1, ColourLayout::kBayerRGGB, 4095},
      {PixelFormat::kBayerRG16, "BayerRG16", 16, 2, 1, ColourLayout::kBayerRGGB, 65535},
      {PixelFormat::kRgb8, "RGB8", 8, 1, 3, ColourLayout::kRgb, 255},
  };
  ASSERT_EQ(std::size(kPixelFormats), std::size(expected));
  for (const auto& e : expected) {
    const PixelFormatInfo& info = pixel_format_info(e.format);
    EXPECT_EQ(info.format, e.format);
    EXPECT_EQ(info.name, e.name);
    EXPECT_EQ(info.significant_bits, e.bits) << e.name;
    EXPECT_EQ(info.bytes_per_sample, e.bytes) << e.name;
    EXPECT_EQ(info.samples_per_pixel, e.samples) << e.name;
    EXPECT_EQ(info.layout, e.layout) << e.name;
    EXPECT_EQ(info.full_scale(), e.full_scale) << e.name;
    EXPECT_EQ(info.frame_bytes(37, 11), 37u * 11u * static_cast<std::size_t>(e.bytes * e.samples)) << e.name;
    // Names and PFNC codes map back to the format.
    EXPECT_EQ(parse_pixel_format(e.name), e.format);
    EXPECT_EQ(pixel_format_from_pfnc(info.pfnc_code), e.format) << e.name;
  }
  // GigE Vision PFNC codes (the standard's values, as Aravis defines them).
  EXPECT_EQ(pixel_format_info(PixelFormat::kMono8).pfnc_code, 0x01080001u);
  EXPECT_EQ(pixel_format_info(PixelFormat::kBayerRG12).pfnc_code, 0x01100011u);
  EXPECT_EQ(pixel_format_info(PixelFormat::kRgb8).pfnc_code, 0x02180014u);
}

TEST(PixelFormatTable, RefusesUnknownNamesAndCodes) {
  EXPECT_EQ(parse_pixel_format("bayerrg12"), std::nullopt);  // exact, case-sensitive
  EXPECT_EQ(parse_pixel_format("BayerGB8"), std::nullopt);
  EXPECT_EQ(parse_pixel_format(""), std::nullopt);
  EXPECT_EQ(pixel_format_from_pfnc(0x0108000Au), std::nullopt);  // BayerGB8: not offered
  EXPECT_EQ(pixel_format_names(), "Mono8, Mono12, Mono16, BayerRG8, BayerRG12, BayerRG16, RGB8");
}

}  // namespace
}  // namespace chromo::drivers
