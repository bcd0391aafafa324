// The one bounded reader of data files (files/bounded_read.hpp) and the
// OpenEXR header check before OpenEXR reads a file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "chromo/files/bounded_read.hpp"
#include "chromo/files/float_image.hpp"

namespace chromo::files {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

class BoundedRead : public ::testing::Test {
 protected:
  fs::path dir = fs::temp_directory_path() / ("chromo_bounded_read_" + std::to_string(::getpid()));
  void SetUp() override { fs::create_directories(dir); }
  void TearDown() override { fs::remove_all(dir); }
  std::string refusal(const std::function<void()>& f) {
    try {
      f();
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "(not refused)";
  }
};

TEST_F(BoundedRead, ReadsARegularFileWhole) {
  std::ofstream(dir / "a.csv") << "wavelength_nm,value\n400,1\n";
  EXPECT_EQ(read_text_file(dir / "a.csv", "CSV"), "wavelength_nm,value\n400,1\n");
  EXPECT_EQ(read_bounded(dir / "a.csv", 26, "CSV").size(), 26u);  // exactly at the cap
}

TEST_F(BoundedRead, RefusesWhatIsNotARegularFileNamingThePathAndKind) {
  EXPECT_THAT(refusal([&] { read_text_file("/dev/zero", "CSV"); }),
              HasSubstr("/dev/zero: not a regular file (a character device)"));
  EXPECT_THAT(refusal([&] { read_text_file(dir, "JSON"); }), HasSubstr(dir.string() + ": not a regular file (a directory)"));
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_THAT(refusal([&] { read_text_file(dir / "fifo", "JSON"); }), HasSubstr("not a regular file (a FIFO)"));
  EXPECT_THAT(refusal([&] { read_text_file(dir / "missing.json", "JSON"); }),
              HasSubstr("missing.json: cannot open (No such file or directory)"));
}

TEST_F(BoundedRead, RefusesAFileOverTheCapNamingTheCap) {
  std::ofstream(dir / "a.csv") << std::string(27, 'x');
  EXPECT_THAT(refusal([&] { read_bounded(dir / "a.csv", 26, "CSV"); }),
              HasSubstr("a.csv: 27 bytes, over the 26 bytes cap for CSV files"));
  std::ofstream(dir / "big.json") << "{}";
  fs::resize_file(dir / "big.json", kMaxTextFileBytes + 1);
  EXPECT_THAT(refusal([&] { read_text_file(dir / "big.json", "JSON"); }),
              HasSubstr("16777217 bytes, over the 16 MiB cap for JSON files"));
}

TEST_F(BoundedRead, ImageSizesAreCappedAtSixtyFourMegapixels) {
  EXPECT_NO_THROW(check_image_size("a", 8000, 8000));
  EXPECT_THAT(refusal([] { check_image_size("a.png", 8001, 8000); }),
              HasSubstr("a.png: image size 8001×8000 is over the 64 MP cap per image"));
  EXPECT_THAT(refusal([] { check_image_size("a.png", 0, 10); }), HasSubstr("is not positive"));
  EXPECT_THAT(refusal([] { check_image_size("a.png", 1ll << 40, 1ll << 40); }), HasSubstr("over the 64 MP cap"));
}

TEST_F(BoundedRead, AnExrHeaderIsCheckedBeforeOpenExrReadsTheFile) {
  FloatImage image;
  image.width = 5, image.height = 3;
  image.channel_names = {"Y"};
  image.channels = {std::vector<float>(15, 0.25f)};
  write_exr(dir / "a.exr", image);
  const ExrSize size = check_exr_file(dir / "a.exr");
  EXPECT_EQ(size.width, 5);
  EXPECT_EQ(size.height, 3);
  EXPECT_EQ(read_exr(dir / "a.exr").channel("Y")[14], 0.25f);

  std::ifstream in(dir / "a.exr", std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  std::string bytes = s.str();
  const std::string key("dataWindow\0box2i\0", 17);
  const auto at = bytes.find(key);
  ASSERT_NE(at, std::string::npos);
  const std::int32_t box[4] = {-2000000000, 0, 2000000000, 30000};
  std::memcpy(bytes.data() + at + key.size() + 4, box, 16);
  std::ofstream(dir / "huge.exr", std::ios::binary) << bytes;
  EXPECT_THAT(refusal([&] { read_exr(dir / "huge.exr"); }),
              HasSubstr("huge.exr: image size 4000000001×30001 is over the 64 MP cap per image"));
  std::ofstream(dir / "short.exr", std::ios::binary) << bytes.substr(0, at + 10);
  EXPECT_THAT(refusal([&] { read_exr(dir / "short.exr"); }), HasSubstr("short.exr: not a readable OpenEXR file"));
  EXPECT_THAT(refusal([&] { read_exr("/dev/zero"); }), HasSubstr("/dev/zero: not a regular file"));
}

}  // namespace
}  // namespace chromo::files
