// Versioned binary cache files: a round trip, and every kind of bad file reads
// as a miss (so the caller rebuilds) instead of as content.
#include <fstream>

#include <gtest/gtest.h>

#include "chromo/files/binary_cache.hpp"
#include "chromo/files/temporary_file.hpp"
#include "../support/fresh_directory.hpp"

namespace chromo::files {
namespace {

namespace fs = std::filesystem;
using testing::fresh_directory;

constexpr CacheFormat kFormat{{'C', 'H', 'R', 'O', 'T', 'E', 'S', 'T'}, 3};
constexpr std::uint64_t kKey = 0x0123456789abcdefull;

std::vector<std::uint8_t> sample_payload() {
  CacheWriter w;
  w.put<std::int32_t>(-7);
  w.put(2.5);
  w.put_vector(std::vector<float>{1.0f, 2.0f, 3.0f});
  return w.bytes();
}

std::vector<char> file_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void overwrite(const fs::path& file, const std::vector<char>& bytes) {
  std::ofstream(file, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

class BinaryCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fresh_directory("binary_cache");
    file_ = dir_ / "sub" / cache_file_name("sample", kKey);  // the folder is made by write_cache
    write_cache(file_, kFormat, kKey, sample_payload());
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_, file_;
};

TEST_F(BinaryCacheTest, RoundTripsThePayload) {
  EXPECT_EQ(file_.filename(), "sample_0123456789abcdef.bin");
  const auto payload = read_cache(file_, kFormat, kKey);
  ASSERT_TRUE(payload);
  EXPECT_EQ(*payload, sample_payload());
  CacheReader r(*payload);
  EXPECT_EQ(r.get<std::int32_t>(), -7);
  EXPECT_EQ(r.get<double>(), 2.5);
  EXPECT_EQ(r.get_vector<float>(3), (std::vector<float>{1.0f, 2.0f, 3.0f}));
  EXPECT_TRUE(r.at_end());
  // Only the file itself is left: the temporary was renamed.
  EXPECT_EQ(std::distance(fs::directory_iterator(file_.parent_path()), fs::directory_iterator()), 1);
}

TEST_F(BinaryCacheTest, RewritingReplacesTheFile) {
  CacheWriter w;
  w.put<std::uint8_t>(9);
  write_cache(file_, kFormat, kKey, w.bytes());
  EXPECT_EQ(read_cache(file_, kFormat, kKey), w.bytes());
}

TEST_F(BinaryCacheTest, AMissingFileIsAMiss) {
  EXPECT_FALSE(read_cache(dir_ / "absent.bin", kFormat, kKey));
}

TEST_F(BinaryCacheTest, AnotherMagicVersionOrKeyIsAMiss) {
  CacheFormat other_magic = kFormat;
  other_magic.magic[7] = 'X';
  CacheFormat other_version = kFormat;
  other_version.version = 4;
  std::string why;
  EXPECT_FALSE(read_cache(file_, other_magic, kKey, &why));
  EXPECT_EQ(why, "another kind of file (its magic is not CHROTESX)");
  EXPECT_FALSE(read_cache(file_, other_version, kKey, &why));
  EXPECT_EQ(why, "another format version (3, this build reads 4)");
  EXPECT_FALSE(read_cache(file_, kFormat, kKey + 1, &why));
  EXPECT_EQ(why, "another key");
  EXPECT_TRUE(read_cache(file_, kFormat, kKey, &why));
  EXPECT_EQ(why, "");
}

TEST_F(BinaryCacheTest, ATruncatedFileIsAMiss) {
  const auto bytes = file_bytes(file_);
  for (std::size_t keep : {std::size_t{0}, std::size_t{10}, std::size_t{28}, bytes.size() - 9, bytes.size() - 1}) {
    overwrite(file_, {bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(keep)});
    EXPECT_FALSE(read_cache(file_, kFormat, kKey)) << "kept " << keep << " of " << bytes.size() << " bytes";
  }
}

TEST_F(BinaryCacheTest, TrailingBytesAreAMiss) {
  auto bytes = file_bytes(file_);
  bytes.push_back(0);
  overwrite(file_, bytes);
  EXPECT_FALSE(read_cache(file_, kFormat, kKey));
}

TEST_F(BinaryCacheTest, ACorruptedLengthIsAMiss) {
  auto bytes = file_bytes(file_);
  for (std::uint64_t length : {std::uint64_t{0}, std::uint64_t{1} << 40, ~std::uint64_t{0}}) {
    std::memcpy(bytes.data() + 20, &length, sizeof length);  // payload_bytes (the layout in the header)
    overwrite(file_, bytes);
    std::string why;
    EXPECT_FALSE(read_cache(file_, kFormat, kKey, &why)) << length;
    EXPECT_NE(why.find("corrupted length"), std::string::npos) << why;
  }
}

TEST_F(BinaryCacheTest, ACorruptedPayloadByteIsAMiss) {
  auto bytes = file_bytes(file_);
  bytes[28 + 5] ^= 0x10;  // one bit of the double
  overwrite(file_, bytes);
  std::string why;
  EXPECT_FALSE(read_cache(file_, kFormat, kKey, &why));
  EXPECT_EQ(why, "checksum mismatch (corrupted bytes)");
}

TEST(CacheReader, ReadingPastTheEndFailsAndStaysFailed) {
  const auto payload = sample_payload();
  CacheReader r(payload);
  r.get<std::int32_t>(), r.get<double>(), r.get_vector<float>(3);
  EXPECT_TRUE(r.at_end());
  EXPECT_EQ(r.get<std::int32_t>(), 0);  // past the end
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.at_end());
  EXPECT_TRUE(r.get_vector<float>(3).empty());
}

TEST(CacheReader, AVectorOverItsLimitOrThePayloadFails) {
  const auto payload = sample_payload();
  CacheReader over_limit(payload);
  over_limit.get<std::int32_t>(), over_limit.get<double>();
  EXPECT_TRUE(over_limit.get_vector<float>(2).empty());
  EXPECT_FALSE(over_limit.ok());
  CacheReader over_payload(payload);
  over_payload.get<std::int32_t>(), over_payload.get<double>();
  EXPECT_TRUE(over_payload.get_vector<double>(100).empty());  // 3 doubles do not fit in 12 bytes
  EXPECT_FALSE(over_payload.ok());
  CacheReader exact(payload);
  exact.get<std::int32_t>(), exact.get<double>();
  EXPECT_EQ(exact.get_vector<float>(3).size(), 3u);
  EXPECT_TRUE(exact.at_end());
}

TEST(BinaryCache, AWriteThatFailsNamesTheFileAndLeavesNothing) {
  const auto dir = fresh_directory("binary_cache_fail");
  const fs::path file = dir / "blocked" / "a.bin";
  std::ofstream(dir / "blocked") << "a file where the folder should be";
  try {
    write_cache(file, kFormat, kKey, sample_payload());
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  fs::remove_all(dir);
}

// Issue 19: the table cache grew ~77 MB per measurement set without bound.
// A folder is kept within the limit, least recently used evicted first.
TEST(BinaryCacheBound, EvictsTheLeastRecentlyUsedBeyondTheLimit) {
  const auto dir = fresh_directory("binary_cache_bound");
  const std::vector<std::uint8_t> payload(1000, 7);  // each file: 1000 + 36 bytes
  const auto previous = cache_limit_bytes();
  set_cache_limit_bytes(3 * 1036);
  auto name = [](int i) { return cache_file_name("table", 100 + i); };
  std::ofstream(dir / "notes.txt") << std::string(5000, 'x');  // not a cache file: neither counted nor touched
  for (int i = 0; i < 3; ++i) {
    write_cache(dir / name(i), kFormat, 100 + i, payload);
    fs::last_write_time(dir / name(i), fs::file_time_type::clock::now() - std::chrono::hours(10 - i));
  }
  // Reading the oldest makes it the most recently used.
  ASSERT_TRUE(read_cache(dir / name(0), kFormat, 100).has_value());
  write_cache(dir / name(3), kFormat, 103, payload);  // 4 files > 3: the least recently used (1) goes
  EXPECT_TRUE(fs::exists(dir / name(0)));
  EXPECT_FALSE(fs::exists(dir / name(1)));
  EXPECT_TRUE(fs::exists(dir / name(2)));
  EXPECT_TRUE(fs::exists(dir / name(3)));
  EXPECT_TRUE(fs::exists(dir / "notes.txt"));
  // A file larger than the whole bound is kept alone (it was just written).
  set_cache_limit_bytes(500);
  write_cache(dir / name(4), kFormat, 104, payload);
  EXPECT_TRUE(fs::exists(dir / name(4)));
  for (int i : {0, 2, 3}) EXPECT_FALSE(fs::exists(dir / name(i))) << i;
  set_cache_limit_bytes(previous);
  fs::remove_all(dir);
}

TEST(BinaryCacheBound, TheDefaultBoundIsTwoGiB) {
  EXPECT_EQ(kDefaultCacheLimitBytes, 2ull << 30);
  const auto dir = fresh_directory("binary_cache_trim");
  const std::vector<std::uint8_t> payload(100, 1);
  for (int i = 0; i < 4; ++i) write_cache(dir / cache_file_name("t", i), kFormat, i, payload);
  EXPECT_EQ(trim_cache_folder(dir, 2 * 136), 2u * 136u);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 2);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace chromo::files
