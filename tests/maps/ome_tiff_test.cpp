// maps.ome.tiff generic over the map image's channels (sigma_* and channels
// this library does not know), read back through libtiff: one float32 page
// per channel in the documented order, tiled, Deflate without predictor,
// names and units in the OME-XML, values bit for bit; a malformed image
// refused with nothing written.
#include <gtest/gtest.h>
#include <tiffio.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include "chromo/files/durable_file.hpp"
#include "chromo/maps/ome_tiff.hpp"

namespace fs = std::filesystem;
using namespace chromo;

namespace {

files::FloatImage generic_maps(int width, int height) {
  files::FloatImage image;
  image.width = width, image.height = height;
  image.channel_names = {"zeta", "sigma_Cm", "flags", "Cm"};
  for (int c = 0; c < 4; ++c) {
    std::vector<float> values(static_cast<std::size_t>(width) * height);
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<float>(c * 1000 + i) * 0.001f;
    image.channels.push_back(values);
  }
  image.channels[3][5] = std::numeric_limits<float>::quiet_NaN();
  return image;
}

// Every page's samples, untiled, and the first page's description.
std::vector<std::vector<float>> read_pages(const fs::path& path, std::string& description, int& compression,
                                           int& predictor) {
  TIFF* tif = TIFFOpen(path.c_str(), "r");
  EXPECT_NE(tif, nullptr);
  std::vector<std::vector<float>> pages;
  char* text = nullptr;
  if (TIFFGetField(tif, TIFFTAG_IMAGEDESCRIPTION, &text)) description = text;
  std::uint16_t c = 0, p = 1;
  TIFFGetField(tif, TIFFTAG_COMPRESSION, &c);
  TIFFGetFieldDefaulted(tif, TIFFTAG_PREDICTOR, &p);
  compression = c, predictor = p;
  do {
    std::uint32_t width = 0, height = 0, tile_w = 0, tile_h = 0;
    TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &width);
    TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &height);
    EXPECT_TRUE(TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tile_w));
    TIFFGetField(tif, TIFFTAG_TILELENGTH, &tile_h);
    std::vector<float> tile(static_cast<std::size_t>(tile_w) * tile_h), page(static_cast<std::size_t>(width) * height);
    for (std::uint32_t y0 = 0; y0 < height; y0 += tile_h)
      for (std::uint32_t x0 = 0; x0 < width; x0 += tile_w) {
        EXPECT_GT(TIFFReadTile(tif, tile.data(), x0, y0, 0, 0), 0);
        for (std::uint32_t y = y0; y < std::min(height, y0 + tile_h); ++y)
          for (std::uint32_t x = x0; x < std::min(width, x0 + tile_w); ++x)
            page[y * width + x] = tile[(y - y0) * tile_w + (x - x0)];
      }
    pages.push_back(page);
  } while (TIFFReadDirectory(tif));
  TIFFClose(tif);
  return pages;
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST(OmeTiff, AnyChannelsInTheDocumentedOrderWithUnitsAndExactValues) {
  const fs::path dir = fs::path(testing::TempDir()) / "ome_tiff_generic";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const files::FloatImage maps = generic_maps(300, 270);  // edge tiles on both axes
  files::commit_file_durably(dir / "maps.ome.tiff", nullptr,
                             [&](const fs::path& t) { maps::write_maps_ome_tiff(t, maps, {12.5, 2}); });
  std::string xml;
  int compression = 0, predictor = 0;
  const auto pages = read_pages(dir / "maps.ome.tiff", xml, compression, predictor);
  EXPECT_EQ(compression, COMPRESSION_ADOBE_DEFLATE);
  EXPECT_EQ(predictor, PREDICTOR_NONE);
  ASSERT_EQ(pages.size(), 4u);
  // Cm, flags (known), sigma_Cm, then zeta.
  const int source[4] = {3, 2, 1, 0};
  for (int page = 0; page < 4; ++page)
    for (std::size_t i = 0; i < pages[page].size(); ++i)
      ASSERT_TRUE(same_bits(pages[page][i], maps.channels[source[page]][i])) << "page " << page << " pixel " << i;
  EXPECT_TRUE(std::isnan(pages[0][5]));
  const auto at = [&](const std::string& text) { return xml.find(text); };
  EXPECT_LT(at(R"(Name="Cm")"), at(R"(Name="flags")"));
  EXPECT_LT(at(R"(Name="flags")"), at(R"(Name="sigma_Cm")"));
  EXPECT_LT(at(R"(Name="sigma_Cm")"), at(R"(Name="zeta")"));
  EXPECT_NE(at(R"(SizeC="4")"), std::string::npos);
  EXPECT_NE(at(R"(PhysicalSizeX="12.5")"), std::string::npos);
  EXPECT_NE(at(R"(<M K="unit:sigma_Cm">volume fraction</M>)"), std::string::npos);
  EXPECT_NE(at(R"(<M K="meaning:sigma_Cm">standard deviation of Cm</M>)"), std::string::npos);
  EXPECT_NE(at(R"(<M K="unit:zeta"></M>)"), std::string::npos);
  EXPECT_NE(at(R"(<M K="flag:5">unexplained_absorber</M>)"), std::string::npos);
  EXPECT_EQ(maps::map_channel_info("sigma_Ch").unit, "volume fraction");
  EXPECT_EQ(maps::map_channel_info("sigma_nothing").unit, "");
}

TEST(OmeTiff, AMalformedImageIsRefusedAndWritesNothing) {
  const fs::path dir = fs::path(testing::TempDir()) / "ome_tiff_bad";
  fs::remove_all(dir);
  fs::create_directories(dir);
  files::FloatImage maps = generic_maps(20, 10);
  maps.channels[2].pop_back();
  try {
    files::commit_file_durably(dir / "maps.ome.tiff", nullptr,
                               [&](const fs::path& t) { maps::write_maps_ome_tiff(t, maps); });
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("channel flags has 199 values for 200 pixels"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_empty(dir));
}
