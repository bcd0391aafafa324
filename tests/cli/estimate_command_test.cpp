// Runs the real chromo binary on real files: a synthetic measurement (method
// set: D65' RGB + blue-only B) written as OpenEXR + CSV, with the blue capture
// shifted by a few pixels (registration), then checks maps.exr, summary.json
// and the behaviour on bad input.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/grid.hpp"
#include "run_chromo.hpp"

namespace {

namespace fs = std::filesystem;
using namespace chromo;
using ::testing::HasSubstr;

Result run(const std::string& arguments) { return run_chromo(arguments); }

void write_exr(const fs::path& path, int w, int h, const std::array<std::vector<float>, 3>& rgb) {
  Imf::Header header(w, h);
  const char* names[3] = {"R", "G", "B"};
  for (const char* n : names) header.channels().insert(n, Imf::Channel(Imf::FLOAT));
  Imf::OutputFile file(path.c_str(), header);
  Imf::FrameBuffer frame;
  for (int c = 0; c < 3; ++c)
    frame.insert(names[c], Imf::Slice(Imf::FLOAT, (char*)rgb[c].data(), sizeof(float), sizeof(float) * w));
  file.setFrameBuffer(frame);
  file.writePixels(h);
}

void write_spectrum(const fs::path& path, const spectral::Spectrum& s) {
  std::ofstream out(path);
  out << "# test illuminant\nwavelength_nm,value\n";
  for (int i = 0; i < spectral::kGridSize; ++i) out << spectral::grid_wavelength_nm(i) << "," << s[i] << "\n";
}

class EstimateCommand : public ::testing::Test {
 protected:
  static constexpr int kWidth = 96, kHeight = 72;
  fs::path dir = fs::temp_directory_path() / ("chromo_estimate_test_" + std::to_string(::getpid()));
  std::vector<estimation::SkinParameters> truth;

  void SetUp() override {
    fs::remove_all(dir);
    fs::create_directories(dir);
    estimation::MeasurementSet set = estimation::method_measurement_set(
        spectral::builtin_camera("nikon_d5100"), spectral::led_d65_metamer(),
        spectral::led_spectrum(spectral::LedType::kBlue));
    // Smooth parameter maps (registration needs structure), noise-free.
    const int pixels = kWidth * kHeight;
    truth.resize(pixels);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        const double blob = std::exp(-(std::pow(x - 40.0, 2) + std::pow(y - 30.0, 2)) / 200.0);
        truth[y * kWidth + x] = {0.03 + 0.1 * blob + 0.015 * std::sin(x / 6.0), 0.02 + 0.05 * (1 - blob) +
                                 0.01 * std::cos(y / 5.0), 0.5, 0.02};
      }
    const Eigen::MatrixXd w = set.weights();
    std::vector<spectral::Spectrum> albedo(truth.size());
    estimation::SkinModel().albedo_batch(truth, albedo);
    std::array<std::vector<float>, 3> broadband, blue;
    for (auto& c : broadband) c.resize(pixels);
    for (auto& c : blue) c.assign(pixels, 0.0f);
    const int shift = 3;  // the subject moved 3 px right between the captures
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        const Eigen::VectorXd m = w * albedo[y * kWidth + x].values().matrix();
        for (int c = 0; c < 3; ++c) broadband[c][y * kWidth + x] = static_cast<float>(m[c]);
        const int xs = std::clamp(x - shift, 0, kWidth - 1);
        const Eigen::VectorXd ms = w * albedo[y * kWidth + xs].values().matrix();
        blue[2][y * kWidth + x] = static_cast<float>(ms[3]);
      }
    write_exr(dir / "d65prime.exr", kWidth, kHeight, broadband);
    write_exr(dir / "blue.exr", kWidth, kHeight, blue);
    write_spectrum(dir / "d65prime.csv", set.channels[0].illuminant);
    write_spectrum(dir / "blue.csv", set.channels[3].illuminant);
    nlohmann::json j = {
        {"camera", "builtin:nikon_d5100"},
        {"images",
         {{{"name", "D65'"}, {"file", "d65prime.exr"}, {"illuminant", "d65prime.csv"}, {"channels", {"R", "G", "B"}}},
          {{"name", "blue"}, {"file", "blue.exr"}, {"illuminant", "blue.csv"}, {"channels", {"B"}}}}}};
    std::ofstream(dir / "measurement.json") << j.dump(2);
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string args(const std::string& rest) {
    return (dir / "measurement.json").string() + " --cache-dir " + (dir / "cache").string() + " " + rest;
  }
};

TEST_F(EstimateCommand, WritesMapsPreviewsAndSummary) {
  const Result r = run("estimate " + args("--model 4d --out " + (dir / "out").string()));
  ASSERT_EQ(r.exit_status, 0) << r.output;
  for (const char* f : {"maps.exr", "summary.json", "cm.png", "ch.png", "bm.png", "che.png", "residual.png",
                        "flags.png", "order.png"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  nlohmann::json s = nlohmann::json::parse(std::ifstream(dir / "out" / "summary.json"));
  EXPECT_EQ(s["method"], "fast");
  EXPECT_EQ(s["order_counts"]["4"], s["flag_counts"]["explained"]);
  EXPECT_GT(s["pixels_per_second"].get<double>(), 0);
  EXPECT_EQ(s["pixels"], kWidth * kHeight);
  ASSERT_EQ(s["registration"].size(), 1u);
  EXPECT_NEAR(s["registration"][0]["shift_x_px"].get<double>(), 3.0, 0.3);  // blue(x + 3) = broadband(x)
  EXPECT_LT(s["registration"][0]["residual_motion_px"].get<double>(), 0.5);
  EXPECT_TRUE(s["flag_counts"].contains("unexplained_colour"));

  // maps.exr: the seven float channels and the σ maps; Cm recovered inside the image.
  Imf::InputFile file((dir / "out" / "maps.exr").c_str());
  std::vector<std::string> names;
  for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) names.push_back(it.name());
  EXPECT_THAT(names, ::testing::UnorderedElementsAre("Cm", "Ch", "Bm", "Che", "residual", "order", "flags", "sigma_Cm",
                                                     "sigma_Ch", "sigma_Bm", "sigma_Che", "corr_Ch_Che", "discrepancy_0",
                                                     "discrepancy_1", "discrepancy_2", "discrepancy_3", "discrepancy_4",
                                                     "discrepancy_5"));
  EXPECT_EQ(s["skin_denoise"]["enabled"], true);  // the multi-pixel estimate, on by default
  EXPECT_EQ(s["discrepancy_layer"]["enabled"], true);  // the relit layer, its basis in the header (discrepancy_layer.hpp)
  EXPECT_NE(file.header().findTypedAttribute<Imf::StringAttribute>("chromo.discrepancy_basis"), nullptr);
  std::vector<float> cm(kWidth * kHeight), flags(kWidth * kHeight);
  Imf::FrameBuffer frame;
  frame.insert("Cm", Imf::Slice(Imf::FLOAT, (char*)cm.data(), sizeof(float), sizeof(float) * kWidth));
  frame.insert("flags", Imf::Slice(Imf::FLOAT, (char*)flags.data(), sizeof(float), sizeof(float) * kWidth));
  file.setFrameBuffer(frame);
  file.readPixels(0, kHeight - 1);
  // Away from the border the blue capture's warp leaves (NaN → flagged):
  // everything explained, Cm within 25% everywhere and 5% on average (Cm
  // trades against βm at low melanin). With the multi-pixel estimate (the
  // default since 8 Dec 2026) the worst pixel is 21.3% off, the mean 3.95%;
  // per pixel only (--skin-denoise off) 16.4% and 2.22%: this scene is
  // noise-free and its Cm curves within the 11-px window, so averaging the
  // neighbours' colour shapes within the declared noise bends the extremes.
  int checked = 0;
  double relative_sum = 0, relative_max = 0;
  for (int y = 10; y < kHeight - 10; ++y)
    for (int x = 10; x < kWidth - 10; ++x) {
      const int i = y * kWidth + x;
      relative_max = std::max(relative_max, std::abs(cm[i] - truth[i].cm) / truth[i].cm);
      EXPECT_EQ(flags[i], 0.0f) << x << "," << y;
      EXPECT_NEAR(cm[i], truth[i].cm, 0.25 * truth[i].cm) << x << "," << y;
      relative_sum += std::abs(cm[i] - truth[i].cm) / truth[i].cm;
      ++checked;
    }
  EXPECT_GT(checked, 1000);
  std::printf("Cm relative error inside: mean %.4f, max %.4f\n", relative_sum / checked, relative_max);
  EXPECT_LT(relative_sum / checked, 0.05);
}

// The spatial pass is on by default (flags and order); --no-neighbourhood-flags
// keeps the per-pixel flags only. This image is all skin, noise-free, its Cm
// varying over ~30 px: the pass, measuring deviations against the noise plus the
// skin's own scatter around its background, flags at most 1% of it (0
// measured; the previous, noise-only statistic flagged ~7%).
TEST_F(EstimateCommand, NeighbourhoodFlagsAreOnByDefaultAndCounted) {
  Result r = run("estimate " + args("--out " + (dir / "spatial").string()));
  ASSERT_EQ(r.exit_status, 0) << r.output;
  nlohmann::json s = nlohmann::json::parse(std::ifstream(dir / "spatial" / "summary.json"));
  EXPECT_EQ(s["neighbourhood"]["flags"], true);
  EXPECT_EQ(s["neighbourhood"]["order_pooling"], true);
  std::size_t counted = 0;
  for (const auto& [name, count] : s["flag_counts"].items()) counted += count.get<std::size_t>();
  EXPECT_EQ(counted, static_cast<std::size_t>(kWidth * kHeight));
  // (The registration's border, 3 px wide, is non-finite: flagged per pixel.)
  EXPECT_LE(s["flag_counts"]["neighbourhood"].get<std::size_t>(), static_cast<std::size_t>(kWidth * kHeight / 100));
  EXPECT_EQ(s["flag_counts"]["neighbourhood"].get<std::size_t>(),
            s["neighbourhood"]["flagged_touching_flagged_regions"].get<std::size_t>() +
                s["neighbourhood"]["flagged_enclosed"].get<std::size_t>());
  EXPECT_EQ(s["neighbourhood"]["block_px"], 1);  // a small image: the pass on its pixels
  r = run("estimate " + args("--no-neighbourhood-flags --out " + (dir / "plain").string()));
  ASSERT_EQ(r.exit_status, 0) << r.output;
  s = nlohmann::json::parse(std::ifstream(dir / "plain" / "summary.json"));
  EXPECT_EQ(s["neighbourhood"]["flags"], false);
  EXPECT_EQ(s["flag_counts"]["neighbourhood"], 0);
}

TEST_F(EstimateCommand, TwoDMethodGivesOrderTwoOnly) {
  const Result r = run("estimate " + args("--method 2d --out " + (dir / "out2d").string()));
  ASSERT_EQ(r.exit_status, 0) << r.output;
  nlohmann::json s = nlohmann::json::parse(std::ifstream(dir / "out2d" / "summary.json"));
  EXPECT_EQ(s["method"], "2d");
  EXPECT_EQ(s["order_counts"]["4"], 0);
  EXPECT_GT(s["order_counts"]["2"].get<int>(), 0);
  // The table built by the first run of this fixture's cache is not rebuilt.
  const Result again = run("estimate " + args("--method 2d --out " + (dir / "out2d_again").string()));
  ASSERT_EQ(again.exit_status, 0) << again.output;
  nlohmann::json s2 = nlohmann::json::parse(std::ifstream(dir / "out2d_again" / "summary.json"));
  EXPECT_EQ(s2["table"]["rebuilt"], false);
  EXPECT_EQ(s2["table"]["key"], s["table"]["key"]);
}

TEST_F(EstimateCommand, SummaryNamesTheInverterThatRan) {
  // Seven channels (the D65' capture twice): the fast method runs the
  // subspace inverter there (EstimatorOptions::subspace_beyond_four_channels),
  // and summary.json says so rather than the option's "fast".
  nlohmann::json j = nlohmann::json::parse(std::ifstream(dir / "measurement.json"));
  j["images"].push_back({{"name", "D65' again"}, {"file", "d65prime.exr"}, {"illuminant", "d65prime.csv"},
                         {"channels", {"R", "G", "B"}}});
  std::ofstream(dir / "seven.json") << j.dump(2);
  const Result r = run("estimate " + (dir / "seven.json").string() + " --cache-dir " + (dir / "cache").string() +
                       " --model 4d --out " + (dir / "seven").string());
  ASSERT_EQ(r.exit_status, 0) << r.output;
  nlohmann::json s = nlohmann::json::parse(std::ifstream(dir / "seven" / "summary.json"));
  EXPECT_EQ(s["method"], "subspace");
  EXPECT_EQ(s["channels"].size(), 7u);
  // The same noise-free data: most pixels explained at order 4.
  EXPECT_GT(s["flag_counts"]["explained"].get<int>(), kWidth * kHeight * 9 / 10);
}

TEST_F(EstimateCommand, BadInputExitsTwoAndWritesNothing) {
  // A missing image file.
  std::ofstream(dir / "bad.json") << R"({"camera": "builtin:nikon_d5100", "images": [{"file": "missing.exr",
      "illuminant": "d65prime.csv", "channels": ["R","G","B"]}]})";
  Result r = run("estimate " + (dir / "bad.json").string() + " --out " + (dir / "out_bad").string());
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("missing.exr"));
  EXPECT_FALSE(fs::exists(dir / "out_bad"));
  // A channel name that is not R, G or B.
  std::ofstream(dir / "bad2.json") << R"({"camera": "builtin:nikon_d5100", "images": [{"file": "d65prime.exr",
      "illuminant": "d65prime.csv", "channels": ["R","X"]}]})";
  r = run("estimate " + (dir / "bad2.json").string() + " --out " + (dir / "out_bad").string());
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("\"X\""));
  // Not JSON.
  std::ofstream(dir / "bad3.json") << "{ nope";
  r = run("estimate " + (dir / "bad3.json").string() + " --out " + (dir / "out_bad").string());
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("not valid JSON"));
  // A session directory is not supported yet: said so.
  r = run("estimate " + dir.string() + " --out " + (dir / "out_bad").string());
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("session"));
  EXPECT_FALSE(fs::exists(dir / "out_bad"));
}

TEST(FitSpectrumCommand, FitsTheNistForearmsAsJson) {
  const Result r = run(std::string("fit-spectrum ") + CHROMO_DATA_DIR + "/skin_reflectance_nist.csv --json");
  ASSERT_EQ(r.exit_status, 0) << r.output.substr(0, 400);
  const nlohmann::json a = nlohmann::json::parse(r.output);
  ASSERT_EQ(a.size(), 50u);
  double d65 = 0, a_mean = 0, leds = 0;
  for (const auto& o : a) {
    for (const char* key : {"sample", "cm", "ch", "bm", "che", "specular", "de94_d65", "de94_a", "rms"})
      EXPECT_TRUE(o.contains(key)) << key;
    EXPECT_EQ(o["specular"].get<double>(), 0.0);
    d65 += o["de94_d65"].get<double>() / a.size();
    a_mean += o["de94_a"].get<double>() / a.size();
    leds += o["de94_led_mean"].get<double>() / a.size();
  }
  // Issue 6 targets for the 4D fit; measured 0.195, 0.248, 0.473 (docs/estimation.md).
  EXPECT_LE(d65, 0.2);
  EXPECT_LE(a_mean, 0.25);
  EXPECT_LE(leds, 0.5);
}

TEST(FitSpectrumCommand, RejectsAFileWithoutWavelengths) {
  const fs::path f = fs::temp_directory_path() / ("chromo_fit_bad_" + std::to_string(::getpid()) + ".csv");
  std::ofstream(f) << "# no wavelength column\nx,y\n1,2\n";
  const Result r = run("fit-spectrum " + f.string());
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("wavelength_nm"));
  fs::remove(f);
}

}  // namespace
