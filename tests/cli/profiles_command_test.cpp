// Runs the real `chromo profiles` and reads back what it wrote.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "chromo/files/temporary_file.hpp"
#include "run_chromo.hpp"

using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / name;
  fs::remove_all(dir);
  return dir;
}

// A 3x2 maps.exr with the channels chromo estimate writes.
void write_maps(const fs::path& path, const std::vector<std::pair<const char*, std::vector<float>>>& channels) {
  Imf::Header header(3, 2);
  for (const auto& [name, values] : channels) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
  Imf::OutputFile file(path.c_str(), header);
  Imf::FrameBuffer frame;
  for (const auto& [name, values] : channels)
    frame.insert(name, Imf::Slice(Imf::FLOAT, const_cast<char*>(reinterpret_cast<const char*>(values.data())),
                                  sizeof(float), 3 * sizeof(float)));
  file.setFrameBuffer(frame);
  file.writePixels(2);
}

TEST(ChromoProfiles, WritesTableWhoseProfilesIntegrateToTheAlbedo) {
  const fs::path out = fresh_dir("profiles_table");
  const Result r = run_chromo("profiles --out " + out.string() + " --cm 0.01,0.2 --ch 0.02,0.2 --bm 0.7 --che 0,0.05");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  const auto header = nlohmann::json::parse(std::ifstream(out / "profiles.json"));
  EXPECT_EQ(header["entries"], 8);
  const std::vector<double> radii = header["radius_mm"];
  const std::size_t expected_bytes = 8 * radii.size() * 3 * sizeof(float);
  ASSERT_EQ(fs::file_size(out / "profiles.f32"), expected_bytes);
  EXPECT_LT(header["worst_plane_integral_error"].get<double>(), 0.005);

  // Integrate entry 5 (Cm 0.2, Ch 0.02, Che 0.05) ourselves from the file.
  std::vector<float> data(8 * radii.size() * 3);
  std::ifstream(out / "profiles.f32", std::ios::binary).read(reinterpret_cast<char*>(data.data()), expected_bytes);
  const std::size_t entry = ((1 * 2 + 0) * 1 + 0) * 2 + 1;
  const double log_step = std::log(radii[1] / radii[0]);
  double integral_green = M_PI * radii[0] * radii[0] * data[entry * radii.size() * 3 + 1];
  for (std::size_t i = 0; i < radii.size(); ++i) {
    const double w = (i == 0 || i + 1 == radii.size()) ? 0.5 : 1.0;
    integral_green += w * log_step * 2 * M_PI * radii[i] * radii[i] * data[(entry * radii.size() + i) * 3 + 1];
  }
  EXPECT_NEAR(integral_green / header["albedo_rgb"][entry * 3 + 1].get<double>(), 1.0, 0.005);
  for (const auto& entry : fs::directory_iterator(out))  // no temporary left behind
    EXPECT_FALSE(chromo::files::temporary_writer_pid(entry.path().filename().string())) << entry.path();
}

TEST(ChromoProfiles, IndexMapPointsAtNearestEntryAndSkipsFlaggedPixels) {
  const fs::path out = fresh_dir("profiles_index");
  fs::create_directories(out);
  const fs::path maps = out / "maps.exr";
  write_maps(maps, {{"Cm", {0.011f, 0.19f, 0.01f, 0.3f, 0.01f, NAN}},
                    {"Ch", {0.02f, 0.25f, 0.02f, 0.02f, 0.2f, 0.1f}},
                    {"Bm", {0.7f, 0.7f, 0.7f, 0.7f, 0.7f, 0.7f}},
                    {"Che", {0.0f, 0.06f, 0.0f, 0.0f, 0.0f, 0.0f}},
                    {"flags", {0.0f, 0.0f, 4.0f, 0.0f, 0.0f, 0.0f}}});
  const Result r = run_chromo("profiles --out " + out.string() + " --maps " + maps.string() +
                              " --cm 0.01,0.2 --ch 0.02,0.2 --bm 0.7 --che 0,0.05");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  Imf::InputFile file((out / "index.exr").c_str());
  ASSERT_NE(file.header().channels().findChannel("entry"), nullptr);
  std::vector<std::uint32_t> entries(6);
  Imf::FrameBuffer frame;
  frame.insert("entry", Imf::Slice(Imf::UINT, reinterpret_cast<char*>(entries.data()), 4, 12));
  file.setFrameBuffer(frame);
  file.readPixels(0, 1);
  EXPECT_EQ(entries[0], 0u);           // (0.01, 0.02, -, 0) → entry 0
  EXPECT_EQ(entries[1], 7u);           // (0.2, 0.2, -, 0.05) → last entry
  EXPECT_EQ(entries[2], 0xFFFFFFFFu);  // flagged
  EXPECT_EQ(entries[3], 4u);           // Cm 0.3 → nearest 0.2; Ch 0.02
  EXPECT_EQ(entries[4], 2u);           // Ch 0.2
  EXPECT_EQ(entries[5], 0xFFFFFFFFu);  // NaN
}

TEST(ChromoProfiles, BadInputIsRefusedAndLeavesNothingBehind) {
  const fs::path out = fresh_dir("profiles_bad");
  Result r = run_chromo("profiles --out " + out.string() + " --maps /nonexistent/maps.exr --cm 0.01,0.2 --ch 0.02");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("--maps: /nonexistent/maps.exr: no such file"));
  EXPECT_FALSE(fs::exists(out));

  fs::create_directories(out);
  write_maps(out / "partial.exr", {{"Cm", std::vector<float>(6, 0.1f)}, {"Ch", std::vector<float>(6, 0.1f)}});
  r = run_chromo("profiles --out " + out.string() + " --maps " + (out / "partial.exr").string());
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("no channel 'Bm'"));
  EXPECT_EQ(std::distance(fs::directory_iterator(out), fs::directory_iterator()), 1);  // only our input

  r = run_chromo("profiles --out " + (out / "x").string() + " --ch 0.2,0.1");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("Ch axis must increase strictly"));
  r = run_chromo("profiles --out " + (out / "x").string() + " --cm 0.7");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("Cm axis value 0.700000 is outside"));
  EXPECT_FALSE(fs::exists(out / "x"));
}

}  // namespace
