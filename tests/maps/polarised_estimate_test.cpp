// A polarised session end to end (issue 23 parts 3 and 5): the standard plan
// polarised, rendered in process (rendered_session.hpp: render_polarised_skin
// with 1:200 films, oily regions of 1-20σ), measured by the daemon's capture
// builder and build_method_measurement (the surface map from D65' parallel −
// cross), estimated and written (maps.exr surface and highlight channels,
// polarisation.png, summary.json "highlights"). The unpolarised session
// keeps its outputs and says highlights are found heuristically.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "maps_fixture.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/estimate_report.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::maps {
namespace {

namespace fs = std::filesystem;

simulators::RenderedSessionOptions polarised_options() {
  simulators::RenderedSessionOptions o;
  o.sensor_width = 256, o.sensor_height = 192;
  o.seed = 7;
  o.polarised = true;
  o.oily.count = 10;
  o.noise_free = false;
  return o;
}

const simulators::RenderedSession& polarised_session() {
  static const simulators::RenderedSession s = simulators::render_session(polarised_options());
  return s;
}

TEST(PolarisedEstimate, TheSurfaceMapIsTheSheenOnSkinAndTheSurfaceLayerUnderHighlights) {
  const simulators::RenderedSession& lab = polarised_session();
  const session::MethodMeasurement& m = lab.noisy;
  ASSERT_TRUE(m.polarised());
  ASSERT_EQ(m.surface.size(), lab.pixels());
  EXPECT_EQ(m.exposures.back().capture, "subject D65' parallel");
  EXPECT_EQ(m.photographs.size(), 3u);  // the cross-polarised D65', W57, W57+blue
  EXPECT_GT(lab.surface_sigma, 0.001);
  EXPECT_LT(lab.surface_sigma, 0.003);
  EXPECT_NEAR(lab.sheen, 0.02778, 1e-5);
  const std::vector<float> added = simulators::cell_added_reflection(polarised_options(), lab.surface_sigma);
  const auto skin = static_cast<std::uint8_t>(simulators::SceneRegion::kSkin);
  double sum = 0, sum2 = 0, bias = 0;
  std::size_t n = 0, strong = 0;
  for (std::size_t i = 0; i < lab.pixels(); ++i) {
    if (lab.region[i] == skin) sum += m.surface[i], sum2 += double(m.surface[i]) * m.surface[i], ++n;
    if (added[i] / lab.surface_sigma >= 10) {
      const double truth = lab.sheen + added[i];
      bias += (m.surface[i] - truth) / truth, ++strong;
    }
  }
  ASSERT_GT(n, 8000u);
  ASSERT_GT(strong, 100u);
  const double mean = sum / n, std = std::sqrt(sum2 / n - mean * mean);
  // The sheen as the films pass it in G: (ER − 1)²/(ER + 1)² of F, 0.96-0.98 over the G band.
  EXPECT_GT(mean, 0.0262);
  EXPECT_LT(mean, 0.0275);
  // Its noise is what the camera model predicts (the oily strengths' unit).
  EXPECT_NEAR(std / lab.surface_sigma, 1.0, 0.15);
  // Under strong highlights the surface map is the surface layer, short by the extinction (−2..−5%).
  EXPECT_LT(bias / strong, 0.0);
  EXPECT_GT(bias / strong, -0.05);
}

TEST(PolarisedEstimate, MapsCarryTheSurfaceAndTheOpticalHighlightFlagAndThePanel) {
  const simulators::RenderedSession& lab = polarised_session();
  MethodEstimationOptions options;
  options.estimator.threads = 2;
  options.cache_dir = fs::temp_directory_path() / "chromo-test-forward-tables";
  const fs::path out = testing::fresh_directory("polarised-estimate");
  const FileCommit commit = [](const fs::path& path, const std::function<void(const fs::path&)>& produce) { produce(path); };
  fs::create_directories(out / "polarised");
  const auto result =
      estimate_method_measurement(lab.noisy, lab.noisy.set.camera, 0.99, 0, options, out / "polarised", commit);
  const files::FloatImage maps = files::read_exr(out / "polarised" / "maps.exr");
  const auto at = [&](const std::string& name) {
    const auto found = std::find(maps.channel_names.begin(), maps.channel_names.end(), name);
    EXPECT_NE(found, maps.channel_names.end()) << name;
    return static_cast<std::size_t>(found - maps.channel_names.begin());
  };
  const std::vector<float>& surface = maps.channels[at("surface")];
  const std::vector<float>& highlight = maps.channels[at("highlight")];
  for (std::size_t i = 0; i < surface.size(); i += 97) EXPECT_EQ(surface[i], lab.noisy.surface[i]);
  const std::vector<float> added = simulators::cell_added_reflection(polarised_options(), lab.surface_sigma);
  std::size_t skin = 0, skin_flagged = 0, strong = 0, strong_flagged = 0, flagged = 0;
  for (std::size_t i = 0; i < highlight.size(); ++i) {
    flagged += highlight[i] > 0;
    if (lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin)) ++skin, skin_flagged += highlight[i] > 0;
    if (added[i] / lab.surface_sigma >= 4) ++strong, strong_flagged += highlight[i] > 0;
  }
  EXPECT_LE(double(skin_flagged) / skin, 0.01);
  EXPECT_GE(double(strong_flagged) / strong, 0.95);
  // An information flag: the estimator's flags channel is the one of the same estimate without it.
  const auto summary = nlohmann::json::parse(result.summary_json);
  EXPECT_EQ(summary["highlights"]["detection"], "optical");
  EXPECT_EQ(summary["highlights"]["flagged_pixels"], flagged);
  EXPECT_NE(summary["highlights"]["information_only"].get<std::string>().find("cross-polarised"), std::string::npos);
  EXPECT_NE(summary["relit_delta_e94"]["against"].get<std::string>().find("cross-polarised"), std::string::npos);
  EXPECT_EQ(summary["relit_delta_e94"]["by_illuminant"].size(), 3u);
  const cv::Mat panel = cv::imread((out / "polarised" / "polarisation.png").string());
  ASSERT_FALSE(panel.empty());
  EXPECT_GE(panel.cols, 3 * lab.width);
}

TEST(PolarisedEstimate, AnUnpolarisedSessionIsAsBeforeAndSaysHighlightsAreHeuristic) {
  simulators::RenderedSessionOptions o = testing::tiny_lab_session_options();
  const simulators::RenderedSession lab = simulators::render_session(o);
  EXPECT_FALSE(lab.noisy.polarised());
  EXPECT_EQ(lab.surface_sigma, 0.0);
  MethodEstimationOptions options;
  options.estimator.threads = 2;
  options.cache_dir = fs::temp_directory_path() / "chromo-test-forward-tables";
  const fs::path out = testing::fresh_directory("unpolarised-estimate");
  const FileCommit commit = [](const fs::path& path, const std::function<void(const fs::path&)>& produce) { produce(path); };
  const auto result = estimate_method_measurement(lab.noisy, lab.noisy.set.camera, 0.99, 0, options, out, commit);
  const files::FloatImage maps = files::read_exr(out / "maps.exr");
  // (read back in EXR's alphabetical order)
  EXPECT_EQ(maps.channel_names, (std::vector<std::string>{"Bm", "Ch", "Che", "Cm", "flags", "order", "residual"}));
  EXPECT_FALSE(fs::exists(out / "polarisation.png"));
  const auto summary = nlohmann::json::parse(result.summary_json);
  EXPECT_EQ(summary["highlights"]["detection"], "heuristic");
  // Oily regions need the polarised session (their unit is its surface map's σ).
  o.oily.count = 3;
  EXPECT_THROW(simulators::render_session(o), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::maps
