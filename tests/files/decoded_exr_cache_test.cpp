// DecodedExrCache on real EXR files: a second read is the same decoded
// object without decoding, a rewritten file is decoded again, the bound
// drops the least recently read file, a file above the bound is not kept,
// and a missing file is an error naming it.
#include <gtest/gtest.h>

#include <unistd.h>

#include "chromo/files/decoded_exr_cache.hpp"

namespace chromo::files {
namespace {

namespace fs = std::filesystem;

FloatImage filled(int width, float value) {
  FloatImage image;
  image.width = width, image.height = 10;
  image.channel_names = {"Cm"};
  image.channels = {std::vector<float>(static_cast<std::size_t>(width) * 10, value)};
  return image;
}

TEST(DecodedExrCache, KeepsDecodedFilesUntilTheyChangeWithinItsBound) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("decoded-exr-cache-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  write_exr(dir / "a.exr", filled(10, 1));   // 400 bytes decoded
  write_exr(dir / "b.exr", filled(10, 2));
  DecodedExrCache cache(1000);
  const auto first = cache.read(dir / "a.exr");
  EXPECT_EQ(cache.read(dir / "a.exr"), first);
  EXPECT_EQ(cache.decodes(), 1u);
  EXPECT_EQ(cache.bytes(), 400u);

  write_exr(dir / "a.tmp.exr", filled(10, 5));  // a durable rewrite: a new file renamed in
  fs::rename(dir / "a.tmp.exr", dir / "a.exr");
  const auto second = cache.read(dir / "a.exr");
  EXPECT_NE(second, first);
  EXPECT_EQ(second->channel("Cm")[0], 5.0f);
  EXPECT_EQ(first->channel("Cm")[0], 1.0f);  // a caller's copy stays whole
  EXPECT_EQ(cache.decodes(), 2u);
  EXPECT_EQ(cache.entries(), 1u);

  cache.read(dir / "b.exr");                 // 800 bytes: both kept
  cache.read(dir / "a.exr");                 // a most recent
  write_exr(dir / "c.exr", filled(10, 3));
  cache.read(dir / "c.exr");                 // 1200 > 1000: b dropped
  EXPECT_EQ(cache.entries(), 2u);
  EXPECT_EQ(cache.bytes(), 800u);
  const auto decodes = cache.decodes();
  cache.read(dir / "a.exr");
  EXPECT_EQ(cache.decodes(), decodes);       // a kept
  cache.read(dir / "b.exr");
  EXPECT_EQ(cache.decodes(), decodes + 1);   // b decoded again

  write_exr(dir / "big.exr", filled(30, 4));  // 1200 bytes alone
  EXPECT_EQ(cache.read(dir / "big.exr")->width, 30);
  EXPECT_LE(cache.bytes(), 1000u);
  try {
    cache.read(dir / "missing.exr");
    FAIL() << "no error";
  } catch (const ImageError& error) {
    EXPECT_NE(std::string(error.what()).find("missing.exr"), std::string::npos) << error.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace chromo::files
