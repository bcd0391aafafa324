#include "chromo/maps/relight.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "chromo/maps/map_operations.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/srgb.hpp"
#include "maps_fixture.hpp"

namespace chromo::maps {
namespace {

using ::testing::HasSubstr;
using testing::fresh_directory;
using testing::nothing_written;
using testing::uniform_maps;
using testing::write_maps;

TEST(ResolveIlluminant, NamesLedsCctsAndFiles) {
  EXPECT_EQ(resolve_illuminant("d65").name, "D65");
  EXPECT_EQ(resolve_illuminant("W57").name, "W57");
  EXPECT_GT(resolve_illuminant("B").spectrum.max(), 0.0);
  // Daylight from 5000 K: 6504 K is D65 up to the CIE's rounding of its basis.
  const spectral::Spectrum d65 = spectral::illuminant_d65(), cct = resolve_illuminant("6504K").spectrum;
  for (int i = 20; i < 60; i += 10) EXPECT_NEAR(cct[i] / cct[36], d65[i] / d65[36], 0.02);
  // Planck below 5000 K: 2856 K is illuminant A.
  const spectral::Spectrum a = spectral::illuminant_a(), planck = resolve_illuminant("2856K").spectrum;
  for (int i = 0; i < spectral::kGridSize; i += 8) EXPECT_NEAR(planck[i] / a[i], 1.0, 0.01) << i;
  for (const char* bad : {"", "w99", "500K", "30000K", "12abK", "/no/such/spd.csv"}) {
    try {
      resolve_illuminant(bad);
      ADD_FAILURE() << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("illuminant")) << bad;
    }
  }
}

// A flat patch relit through the maps equals the forward model's albedo seen
// under the illuminant, by MODEL.md's colour rules.
TEST(Relight, FlatPatchEqualsTheForwardModel) {
  const estimation::SkinParameters p{0.08, 0.05, 0.6, 0.02};
  ParameterMaps maps = uniform_maps(5, 3, p.cm, p.ch, p.bm, p.che);
  maps.flags[4] = 2.0f;  // saturated: not relit
  const estimation::SkinModel model;
  const spectral::Spectrum albedo = model.albedo(p);
  for (const char* name : {"D65", "A", "W27", "R"}) {
    const spectral::Spectrum e = resolve_illuminant(name).spectrum;
    const RelitImage relit = relight(maps, linear_srgb_weights(e), 1);
    const spectral::Rgb expected =
        spectral::linear_srgb_from_xyz(spectral::xyz_of_reflectance(albedo, e), spectral::white_point(e));
    EXPECT_NEAR(relit.rgb[0], expected.r, 1e-5) << name;
    EXPECT_NEAR(relit.rgb[1], expected.g, 1e-5) << name;
    EXPECT_NEAR(relit.rgb[2], expected.b, 1e-5) << name;
    EXPECT_EQ(relit.valid[4], 0);
    EXPECT_EQ(relit.rgb[12], 0.0f);
    EXPECT_EQ(relit.valid[14], 1);
  }
  // A white albedo maps to (1, 1, 1) under any illuminant.
  const auto w = linear_srgb_weights(resolve_illuminant("W57").spectrum);
  const Eigen::Vector3d white = w * Eigen::VectorXd::Ones(spectral::kGridSize);
  EXPECT_NEAR(white[0], 1.0, 2e-3);
  EXPECT_NEAR(white[1], 1.0, 2e-3);
  EXPECT_NEAR(white[2], 1.0, 2e-3);
}

TEST(RelightToFiles, WritesImagesAndComparesWithAPhotograph) {
  const auto dir = fresh_directory("relight");
  ParameterMaps maps = uniform_maps(16, 8, 0.05f, 0.03f, 0.7f, 0.0f);
  for (int i = 0; i < 64; ++i) maps.ch[i] = 0.1f;  // top half redder
  write_maps(dir / "maps.exr", maps);
  // The photograph: the model's own camera image, then a brighter copy.
  const spectral::Spectrum a = spectral::illuminant_a();
  const auto camera = spectral::builtin_camera("nikon_d5100");
  const RelitImage exact = relight(maps, spectral::camera_weights(camera, a), 1);
  files::FloatImage photo{16, 8, {"R", "G", "B"}, std::vector<std::vector<float>>(3, std::vector<float>(128))};
  for (int i = 0; i < 128; ++i)
    for (int c = 0; c < 3; ++c) photo.channels[c][i] = exact.rgb[3 * i + c];
  files::write_exr(dir / "photo.exr", photo);

  RelightOptions o;
  o.maps = dir / "maps.exr", o.illuminant = "A", o.out = dir / "out", o.photograph = dir / "photo.exr";
  const RelightSummary s = relight_to_files(o);
  EXPECT_EQ(s.relit_pixels, 128u);
  EXPECT_TRUE(s.compared);
  EXPECT_LT(s.photo_delta_e94.max, 1e-3);
  for (const char* f : {"relit.exr", "relit.png", "panel.png", "delta_e94.exr", "relight.json"})
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / f)) << f;
  const files::FloatImage relit = files::read_exr(dir / "out" / "relit.exr");
  EXPECT_EQ(relit.channel("valid")[0], 1.0f);
  const auto j = nlohmann::json::parse(std::ifstream(dir / "out" / "relight.json"));
  EXPECT_EQ(j["illuminant"], "A");
  EXPECT_EQ(j["photo_delta_e94"]["pixels"], 128);

  // 10% brighter photograph: a uniform, known lightness difference.
  for (auto& channel : photo.channels)
    for (float& v : channel) v *= 1.1f;
  files::write_exr(dir / "photo.exr", photo);
  const RelightSummary brighter = relight_to_files(o);
  EXPECT_GT(brighter.photo_delta_e94.mean, 1.5);
  EXPECT_LT(brighter.photo_delta_e94.max - brighter.photo_delta_e94.median, 0.6);
  std::filesystem::remove_all(dir);
}

TEST(RelightToFiles, BadInputNamesTheFieldAndWritesNothing) {
  const auto dir = fresh_directory("relight-bad");
  write_maps(dir / "maps.exr", uniform_maps(8, 8, 0.05f, 0.03f, 0.7f, 0.0f));
  files::FloatImage small{4, 4, {"R", "G", "B"}, std::vector<std::vector<float>>(3, std::vector<float>(16, 0.3f))};
  files::write_exr(dir / "small.exr", small);
  files::FloatImage no_b{8, 8, {"R", "G"}, std::vector<std::vector<float>>(2, std::vector<float>(64, 0.3f))};
  files::write_exr(dir / "no_b.exr", no_b);
  files::write_exr(dir / "no_cm.exr", no_b);
  struct Case {
    std::string maps, illuminant, photo, expected;
  };
  for (const Case& c : {Case{"missing.exr", "D65", "", "maps: "}, Case{"no_cm.exr", "D65", "", "maps: "},
                        Case{"maps.exr", "D66", "", "illuminant: "}, Case{"maps.exr", "D65", "small.exr", "photograph: "},
                        Case{"maps.exr", "D65", "no_b.exr", "photograph: "}}) {
    RelightOptions o;
    o.maps = dir / c.maps, o.illuminant = c.illuminant, o.out = dir / "out";
    if (!c.photo.empty()) o.photograph = dir / c.photo;
    try {
      relight_to_files(o);
      ADD_FAILURE() << c.expected;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), ::testing::StartsWith(c.expected));
    }
    EXPECT_TRUE(nothing_written(dir / "out")) << c.expected;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace chromo::maps
