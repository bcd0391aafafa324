// Issue 19's probes, each on the real chromo binary: data files that are not
// regular files or are over their cap, images whose header claims more than
// 64 MP, non-finite and absurd numbers. Every one exits 2 with a message
// naming the file and the field, prints no result and allocates nothing big.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <functional>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/led_library_io.hpp"
#include "chromo/files/float_image.hpp"
#include "run_chromo.hpp"

namespace {
namespace fs = std::filesystem;
using namespace chromo;
using ::testing::HasSubstr;
using ::testing::Not;

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
void spit(const fs::path& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

class BadInput : public ::testing::Test {
 protected:
  fs::path dir = fs::temp_directory_path() / ("chromo_bad_input_test_" + std::to_string(::getpid()));
  // Memory is bounded: a probe that allocated what its header claims (10.6 GB
  // for 30000×30000 float RGB) fails under this address-space limit.
  const std::string limited = "ulimit -v 4000000;";

  void SetUp() override {
    fs::remove_all(dir);
    fs::create_directories(dir);
    const Result made = run_chromo("make-maps-test-data --out " + (dir / "data").string() + " --width 32 --height 24");
    ASSERT_EQ(made.exit_status, 0) << made.output;
  }
  void TearDown() override { fs::remove_all(dir); }

  // MEASUREMENT.json of the test data with `change` applied, written as `name`.
  fs::path measurement_with(const std::string& name, const std::function<void(nlohmann::json&)>& change) {
    nlohmann::json j = nlohmann::json::parse(slurp(dir / "data" / "MEASUREMENT.json"));
    change(j);
    const fs::path path = dir / "data" / name;
    spit(path, j.dump());
    return path;
  }
  std::string library_json_with(double value) {
    nlohmann::json j = nlohmann::json::parse(calibration::led_library_to_json(calibration::nominal_led_library()));
    for (auto& led : j["leds"])
      for (auto& rung : led["ladder"])
        for (auto& v : rung["spectrum"]) v = value;
    return j.dump();
  }
};

TEST_F(BadInput, DevZeroAsACsvIsRefusedAtOnceNamingThePath) {
  const Result r = run_chromo("fit-spectrum /dev/zero", limited);
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("/dev/zero: not a regular file (a character device)"));
}

TEST_F(BadInput, AFifoIsRefusedWithoutBlocking) {
  const fs::path fifo = dir / "spectra.csv";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const Result r = run_chromo("fit-spectrum " + fifo.string());
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr(fifo.string() + ": not a regular file (a FIFO)"));
}

TEST_F(BadInput, ADirectoryAsAnIlluminantIsRefusedNamingTheImageAndPath) {
  const fs::path m = measurement_with("dir_illuminant.json", [&](nlohmann::json& j) {
    j["images"][0]["illuminant"] = dir.string();
  });
  const Result r = run_chromo("estimate " + m.string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("images[0]"));
  EXPECT_THAT(r.output, HasSubstr(dir.string() + ": not a regular file (a directory)"));
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST_F(BadInput, ACsvOverSixteenMebibytesIsRefusedNamingTheCap) {
  const fs::path big = dir / "big.csv";
  spit(big, "wavelength_nm,a\n");
  fs::resize_file(big, (16u << 20) + 1);  // sparse: nothing is written
  const Result r = run_chromo("fit-spectrum " + big.string(), limited);
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr(big.string() + ": 16777217 bytes, over the 16 MiB cap for CSV files"));
}

TEST_F(BadInput, AnOverflowingReflectanceIsRefusedNamingFileAndColumnAndPrintsNothing) {
  std::string csv = "wavelength_nm,forearm\n";
  for (int nm = 380; nm <= 780; nm += 5) csv += std::to_string(nm) + "," + (nm == 550 ? "1e308" : "0.4") + "\n";
  spit(dir / "fit.csv", csv);
  const Result r = run_chromo("fit-spectrum " + (dir / "fit.csv").string());
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("fit.csv: column 'forearm': reflectance 1e+308 is outside [-0.1, 1.5]"));
  EXPECT_THAT(r.output, Not(HasSubstr("nan")));
  EXPECT_THAT(r.output, Not(HasSubstr("ΔE94")));  // no header printed before the refusal
}

TEST_F(BadInput, AnAbsurdReadSigmaIsRefusedWhereItIsRead) {
  const fs::path m = measurement_with("sigma.json", [](nlohmann::json& j) { j["noise"]["read_sigma"] = 1e308; });
  const Result r = run_chromo("estimate " + m.string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("sigma.json: noise.read_sigma: 1e+308 is outside [0, 1]"));
  EXPECT_THAT(r.output, Not(HasSubstr("terminate")));
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// Issue 40, row 8: one image listed 1000 times reached 15.5 GB. The channels
// are counted before any image is read; 27 (the largest built-in plan) pass.
TEST_F(BadInput, AMeasurementListingTooManyChannelsIsRefusedBeforeReadingAnImage) {
  const fs::path m = measurement_with("many.json", [](nlohmann::json& j) {
    const nlohmann::json first = j["images"][0];
    j["images"] = nlohmann::json::array();
    for (int i = 0; i < 1000; ++i) j["images"].push_back(first);
  });
  const Result r = run_chromo("estimate " + m.string() + " --out " + (dir / "out").string(), limited);
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("many.json: images: 1000 images with"));
  EXPECT_THAT(r.output, HasSubstr("over the cap of 32 channels"));
  EXPECT_FALSE(fs::exists(dir / "out"));

  // Nine images of three channels each (27, the multispectral+method plan's
  // count) are admitted: read up to the ninth, whose missing illuminant is
  // what stops them (so nothing is estimated here).
  const fs::path nine = measurement_with("nine.json", [](nlohmann::json& j) {
    nlohmann::json image = j["images"][0];
    image["channels"] = {"R", "G", "B"};
    j["images"] = nlohmann::json::array();
    for (int i = 0; i < 9; ++i) j["images"].push_back(image);
    j["images"][8]["illuminant"] = "no-such-illuminant.csv";
  });
  const Result admitted = run_chromo("estimate " + nine.string() + " --out " + (dir / "out9").string(), limited);
  EXPECT_EQ(admitted.exit_status, 2) << admitted.output;
  EXPECT_THAT(admitted.output, HasSubstr("images[8]"));
  EXPECT_THAT(admitted.output, Not(HasSubstr("over the cap")));
}

// Issue 40, row 15: a MEASUREMENT.json linked to itself ended in an internal
// error (exit 1); it is bad input, refused naming the path.
TEST_F(BadInput, AMeasurementFileLinkedToItselfIsRefusedAsBadInput) {
  const fs::path loop = dir / "loop.json";
  fs::create_symlink(loop, loop);
  const Result r = run_chromo("estimate " + loop.string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr(loop.string() + ": cannot open (Too many levels of symbolic links)"));
  EXPECT_THAT(r.output, Not(HasSubstr("internal error")));
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST_F(BadInput, AnExrWhoseHeaderClaimsThirtyThousandSquaredIsRefusedBeforeAllocating) {
  // A real 4×4 OpenEXR whose data window is then rewritten to 30000×30000.
  files::FloatImage small;
  small.width = small.height = 4;
  small.channel_names = {"B", "G", "R"};
  small.channels.assign(3, std::vector<float>(16, 0.5f));
  const fs::path exr = dir / "data" / "huge.exr";
  files::write_exr(exr, small);
  std::string bytes = slurp(exr);
  const std::string key("dataWindow\0box2i\0", 17);
  const auto at = bytes.find(key);
  ASSERT_NE(at, std::string::npos);
  const std::int32_t box[4] = {0, 0, 29999, 29999};
  bytes.replace(at + key.size() + 4, 16, reinterpret_cast<const char*>(box), 16);
  spit(exr, bytes);
  const fs::path m = measurement_with("huge.json", [](nlohmann::json& j) { j["images"][0]["file"] = "huge.exr"; });
  const Result r = run_chromo("estimate " + m.string() + " --out " + (dir / "out").string(), limited);
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("huge.exr: image size 30000×30000 is over the 64 MP cap per image"));
}

TEST_F(BadInput, APngWhoseHeaderClaimsThirtyThousandSquaredIsRefusedBeforeDecoding) {
  std::string png = slurp(dir / "data" / "melanin.png");
  const unsigned char size[8] = {0, 0, 0x75, 0x30, 0, 0, 0x75, 0x30};  // 30000, 30000 big-endian
  png.replace(16, 8, reinterpret_cast<const char*>(size), 8);
  spit(dir / "data" / "huge.png", png);
  const fs::path d = dir / "data";
  const Result r = run_chromo("import-maps --melanin " + (d / "huge.png").string() + " --hemoglobin " +
                                  (d / "hemoglobin.png").string() + " --albedo " + (d / "MEASUREMENT.json").string() +
                                  " --out " + (dir / "out").string(),
                              limited);
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("melanin"));
  EXPECT_THAT(r.output, HasSubstr("huge.png: image size 30000×30000 is over the 64 MP cap per image"));
}

TEST_F(BadInput, AnLedLibraryOfHugeSpectraIsRefusedNamingTheField) {
  spit(dir / "lib.json", library_json_with(1e308));
  const Result r = run_chromo("leds solve --stability-trials 0 --library " + (dir / "lib.json").string());
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("lib.json: leds: W57.ladder[0].spectrum holds 1e+308, beyond the 1e12 cap"));
  EXPECT_THAT(r.output, Not(HasSubstr("terminate")));
}

TEST_F(BadInput, AnLedLibraryHoldingOneE999IsRefusedNamingTheFile) {
  std::string text = library_json_with(0.25);
  const auto at = text.find("\"spectrum\":[0.25");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 16, "\"spectrum\":[1e999");
  spit(dir / "lib.json", text);
  const Result r = run_chromo("leds solve --stability-trials 0 --library " + (dir / "lib.json").string());
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("lib.json: not valid JSON"));
  EXPECT_THAT(r.output, HasSubstr("number overflow parsing '1e999'"));
}

TEST_F(BadInput, DevZeroAsAnLedLibraryIsRefused) {
  const Result r = run_chromo("leds solve --stability-trials 0 --library /dev/zero", limited);
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("/dev/zero: not a regular file (a character device); LED library files must be regular files"));
}

}  // namespace
