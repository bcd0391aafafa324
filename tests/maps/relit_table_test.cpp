// The relit comparison's fast path (relit_table.hpp, RelitModel::kTable)
// against the exact model, and the report's parallel writing against the
// one-thread writing.
#include "chromo/maps/relit_table.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "maps_fixture.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/estimate_report.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::maps {
namespace {

namespace fs = std::filesystem;

const spectral::CameraSensitivity& camera() {
  static const spectral::CameraSensitivity c = spectral::builtin_camera("nikon_d5100");
  return c;
}

// Lights like a session's photographs': a white LED, a warm one, and white
// plus blue (the W57+blue capture).
std::vector<spectral::Spectrum> lights() {
  const spectral::Spectrum& w57 = spectral::led_spectrum(spectral::LedType::kW57);
  return {w57, spectral::led_spectrum(spectral::LedType::kW27), w57 + 0.4 * spectral::led_spectrum(spectral::LedType::kBlue)};
}

// At the grid's nodes the table holds the model's camera RGB (float storage).
TEST(RelitTable, HoldsTheExactModelAtItsNodes) {
  const auto illuminants = lights();
  const RelitTable table(camera(), illuminants, estimation::TableGrid{}, {}, 2);
  ASSERT_EQ(table.illuminants(), 3u);
  std::vector<estimation::SkinParameters> nodes;
  const std::array<int, 4> indices[] = {{0, 0, 0, 0}, {40, 40, 20, 20}, {12, 30, 14, 0}, {25, 7, 3, 17}};
  for (const auto& index : indices)
    nodes.push_back(table.table().from_grid({double(index[0]), double(index[1]), double(index[2]), double(index[3])}));
  std::vector<Eigen::Vector3d> rgb(3);
  for (std::size_t i = 0; i < illuminants.size(); ++i) {
    const auto exact = relit_camera_rgb(nodes, camera(), illuminants[i]);
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      table.rgb(nodes[k], rgb.data());
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[i][c], exact[k][c], 1e-6 * std::max(1.0, exact[k][c])) << i << " " << k;
    }
  }
}

// Between the nodes: the interpolation's colour error against the exact
// model, as ΔE94 per pixel through the photograph comparison's camera → Lab
// path, over several populations of skin. Stated tolerance (this test):
// mean ≤ 0.03, p95 ≤ 0.08 under every light (measured at 5 MP:
// bench/estimate_stages_bench.cpp).
TEST(RelitTable, InterpolatedColourIsWithinItsToleranceOfTheExactModel) {
  const auto illuminants = lights();
  const RelitTable table(camera(), illuminants, estimation::TableGrid{}, {}, 2);
  for (std::uint64_t seed : {1, 2, 3}) {
    const auto skin = simulators::random_skin_parameters(3000, {0.005, 0.005, 0, 0}, {0.3, 0.2, 1, 0.1}, seed);
    const auto from_table = table.rgb(skin, 2);
    // The batch is the single-pixel lookup, pixel by pixel.
    std::vector<Eigen::Vector3d> one(illuminants.size());
    table.rgb(skin[17], one.data());
    for (std::size_t i = 0; i < illuminants.size(); ++i) EXPECT_EQ(from_table[i][17], one[i]);
    for (std::size_t i = 0; i < illuminants.size(); ++i) {
      const DeltaEStats s = photo_delta_e94(relit_camera_rgb(skin, camera(), illuminants[i]), from_table[i], camera(),
                                            illuminants[i]);
      EXPECT_GT(s.mean, 0.0) << "interpolated, not exact: " << seed << " " << i;
      EXPECT_LE(s.mean, 0.03) << seed << " " << i;
      EXPECT_LE(s.p95, 0.08) << seed << " " << i;
    }
  }
}

TEST(RelitTable, IsCachedLikeTheForwardTable) {
  const fs::path cache = testing::fresh_directory("relit-table-cache");
  const auto illuminants = lights();
  const RelitTable built(camera(), illuminants, estimation::TableGrid{}, cache, 2);
  const RelitTable loaded(camera(), illuminants, estimation::TableGrid{}, cache, 2);
  EXPECT_TRUE(built.rebuilt());
  EXPECT_FALSE(loaded.rebuilt());
  EXPECT_EQ(built.table().values(), loaded.table().values());
  EXPECT_THROW(RelitTable(camera(), {}, estimation::TableGrid{}, {}, 2), std::invalid_argument);
  fs::remove_all(cache);
}

// A table made earlier (chromod prepares it during capture) serves the
// comparison of the photographs it was made for, and only those: with a table
// of other lights the comparison makes its own, so the statistics are those
// of a comparison without one either way.
TEST(RelitTable, APreparedTableServesOnlyThePhotographsItWasMadeFor) {
  const auto illuminants = lights();
  std::vector<estimation::PixelEstimate> estimates(64);
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    estimates[i].parameters = {0.02 + 0.003 * static_cast<double>(i), 0.01 + 0.001 * static_cast<double>(i % 7), 0.6, 0.01};
    estimates[i].flag = estimation::PixelFlag::kExplained;
  }
  std::vector<session::Photograph> photographs;
  for (std::size_t k = 0; k < illuminants.size(); ++k) {
    session::Photograph photo{"light " + std::to_string(k), illuminants[k], {}, std::nullopt};
    for (std::size_t i = 0; i < estimates.size(); ++i)
      photo.rgb.push_back(Eigen::Vector3d(0.3, 0.2, 0.1) * (1 + 0.01 * static_cast<double>(i + k)));
    photographs.push_back(std::move(photo));
  }
  RelitComparisonOptions options;
  options.threads = 2;
  const auto own = compare_with_photographs(estimates, photographs, camera(), options);
  std::vector<spectral::Spectrum> other_lights(illuminants.rbegin(), illuminants.rend());
  for (const bool same_lights : {true, false}) {
    options.prepared =
        std::make_shared<const RelitTable>(camera(), same_lights ? illuminants : other_lights, options.grid, fs::path(), 2);
    EXPECT_EQ(options.prepared->key() == RelitTable::cache_key(camera(), illuminants, options.grid), same_lights);
    const auto with_prepared = compare_with_photographs(estimates, photographs, camera(), options);
    ASSERT_EQ(with_prepared.size(), own.size());
    for (std::size_t k = 0; k < own.size(); ++k) {
      EXPECT_EQ(with_prepared[k].delta_e94.pixels, 64u);
      EXPECT_EQ(with_prepared[k].delta_e94.mean, own[k].delta_e94.mean) << own[k].illuminant;
      EXPECT_EQ(with_prepared[k].delta_e94.p95, own[k].delta_e94.p95) << own[k].illuminant;
    }
  }
}

// A tiny lab session estimated twice on the same tables: as before (exact
// relit comparison, files on one thread) and with the defaults.
// The maps are the same pixels and the previews the same bytes; the relit
// statistics agree within the table's tolerance.
TEST(RelitTable, EstimateWithTheDefaultsMatchesTheExactOneThreadPath) {
  const simulators::RenderedSession lab = simulators::render_session(testing::tiny_lab_session_options());
  ASSERT_EQ(lab.noisy.photographs.size(), 3u);

  MethodEstimationOptions after;
  after.estimator.threads = 2;
  after.cache_dir = fs::temp_directory_path() / "chromo-test-forward-tables";
  MethodEstimationOptions before = after;
  before.relit_model = RelitModel::kExact;
  before.writer_threads = 1;
  const PreparedTables tables = prepare_tables(lab.noisy.set, after);
  const fs::path out = testing::fresh_directory("relit-table-estimate");
  const FileCommit commit = [](const fs::path& path, const std::function<void(const fs::path&)>& produce) { produce(path); };
  fs::create_directories(out / "before");
  fs::create_directories(out / "after");
  const auto b = estimate_measurement(lab.noisy, lab.noisy.set.camera, 0.99, 0, before, out / "before", commit, {},
                                             {}, &tables);
  const auto a = estimate_measurement(lab.noisy, lab.noisy.set.camera, 0.99, 0, after, out / "after", commit, {},
                                             {}, &tables);

  const files::FloatImage mb = files::read_exr(out / "before" / "maps.exr"), ma = files::read_exr(out / "after" / "maps.exr");
  ASSERT_EQ(ma.channel_names, mb.channel_names);
  for (std::size_t c = 0; c < ma.channels.size(); ++c)
    EXPECT_EQ(0, std::memcmp(ma.channels[c].data(), mb.channels[c].data(), ma.channels[c].size() * sizeof(float)))
        << ma.channel_names[c];
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  for (const char* png : {"cm.png", "ch.png", "bm.png", "che.png", "residual.png", "flags.png", "order.png"})
    EXPECT_EQ(bytes(out / "before" / png), bytes(out / "after" / png)) << png;

  ASSERT_EQ(a.relit.size(), 3u);
  ASSERT_EQ(b.relit.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(a.relit[i].delta_e94.pixels, b.relit[i].delta_e94.pixels);
    EXPECT_GT(a.relit[i].delta_e94.pixels, 1000u);
    EXPECT_NEAR(a.relit[i].delta_e94.mean, b.relit[i].delta_e94.mean, 0.02) << a.relit[i].illuminant;
    EXPECT_NEAR(a.relit[i].delta_e94.median, b.relit[i].delta_e94.median, 0.02) << a.relit[i].illuminant;
    EXPECT_NEAR(a.relit[i].delta_e94.p95, b.relit[i].delta_e94.p95, 0.05) << a.relit[i].illuminant;
  }
  // The stages are all timed, writing too (summary.json cannot hold it).
  for (const char* stage : {"measurement_and_registration", "estimate", "neighbourhood", "relit_comparison", "writing"})
    EXPECT_TRUE(std::any_of(a.timings_s.begin(), a.timings_s.end(), [&](const auto& t) { return t.first == stage; }))
        << stage;
  EXPECT_GT(a.seconds("writing"), 0.0);
  EXPECT_NE(a.summary_json.find("\"reconstruction\": \"table\""), std::string::npos);
  EXPECT_NE(b.summary_json.find("\"reconstruction\": \"exact\""), std::string::npos);
  fs::remove_all(out);
}

}  // namespace
}  // namespace chromo::maps
