// The Maps service (proto/chromosphere/v1/maps.proto) over a real gRPC Unix
// socket: each call on real files, and hostile requests refused with the
// field named and nothing written.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <thread>

#include <grpcpp/grpcpp.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <set>

#include "chromo/daemon/server.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/region_statistics.hpp"
#include "chromo/simulators/scene/external_maps_scene.hpp"
#include "chromosphere/v1/maps.grpc.pb.h"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;
namespace pb = chromosphere::v1;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

struct MapsApi : ::testing::Test {
  testing::TestLab lab{"maps-api"};
  std::unique_ptr<Daemon> daemon;
  std::unique_ptr<Server> server;
  std::unique_ptr<pb::MapsService::Stub> stub;
  fs::path data;

  void SetUp() override {
    lab.config.maps_dir = lab.directory / "maps-work";
    daemon = lab.daemon();
    server = std::make_unique<Server>(*daemon);
    stub = pb::MapsService::NewStub(
        grpc::CreateChannel("unix:" + lab.config.unix_socket, grpc::InsecureChannelCredentials()));
    data = lab.directory / "maps-work";
    fs::create_directories(data);
    const std::size_t n = 24 * 16;
    files::FloatImage maps{24, 16, {"Cm", "Ch", "Bm", "Che", "flags"},
                                {std::vector<float>(n, 0.05f), std::vector<float>(n, 0.04f), std::vector<float>(n, 0.7f),
                                 std::vector<float>(n, 0.01f), std::vector<float>(n, 0.0f)}};
    files::write_exr(data / "maps.exr", maps);
  }
  void TearDown() override { server->shutdown(); }
};

TEST_F(MapsApi, RelightFlushAndProfilesWriteTheirFiles) {
  {
    grpc::ClientContext context;
    pb::RelightRequest request;
    request.set_maps_file("maps.exr");
    request.set_illuminant("4000K");
    request.set_label("warm");
    pb::RelightResponse response;
    const grpc::Status status = stub->Relight(&context, request, &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(response.relit_pixels(), 24u * 16u);
    EXPECT_EQ(response.illuminant(), "4000K");
    // A new folder of its own, named after the operation, relative paths only.
    EXPECT_THAT(response.out_dir(), ::testing::MatchesRegex("products/relight-[0-9]{8}T[0-9]{6}Z-[0-9a-f]{6}-warm"));
    EXPECT_TRUE(fs::exists(data / response.out_dir() / "relit.exr"));
    ASSERT_GT(response.files_size(), 0);
    for (const auto& file : response.files()) EXPECT_THAT(file, StartsWith(response.out_dir() + "/"));
    EXPECT_THAT(response.summary_json(), HasSubstr("\"relit_pixels\": 384"));
  }
  {
    grpc::ClientContext context;
    pb::FlushRequest request;
    request.set_maps_file("maps.exr");
    request.mutable_scale()->set_ch(10);  // 0.4 > 0.32: clamped
    auto* e = request.mutable_ellipse();
    e->set_center_x_px(12), e->set_center_y_px(8), e->set_radius_x_px(6), e->set_radius_y_px(4);
    pb::FlushResponse response;
    const grpc::Status status = stub->Flush(&context, request, &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_GT(response.pixels_touched(), 50u);
    EXPECT_DOUBLE_EQ(response.clamped_share(), 0.25);
    EXPECT_THAT(response.out_dir(), StartsWith("products/flush-"));
    EXPECT_TRUE(fs::exists(data / response.out_dir() / "panel.png"));
  }
  {
    grpc::ClientContext context;
    pb::ExportProfilesRequest request;
    request.set_maps_file("maps.exr");
    for (double v : {0.01, 0.1}) request.add_cm(v), request.add_ch(v);
    request.add_bm(0.7), request.add_che(0.0);
    pb::ExportProfilesResponse response;
    const grpc::Status status = stub->ExportProfiles(&context, request, &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(response.entries(), 4u);
    EXPECT_LT(response.worst_plane_integral_error(), 0.005);
    EXPECT_THAT(response.out_dir(), StartsWith("products/profiles-"));
    EXPECT_TRUE(fs::exists(data / response.out_dir() / "index.exr"));
  }
}

// Issue 40, row 7: ExportProfiles had no concurrency limit and kept
// computing after its client's deadline (a 300-profile call with a 3 s
// deadline: 32 more CPU-seconds, output still written). At most
// max_profile_exports run at once now, and an abandoned one stops.
TEST_F(MapsApi, ProfileExportsAreLimitedAndOneAbandonedByItsClientStops) {
  pb::ExportProfilesRequest big;
  big.set_maps_file("maps.exr");
  for (int i = 0; i < 10; ++i) big.add_cm(0.01 + 0.02 * i), big.add_ch(0.01 + 0.02 * i);  // 10 x 10 x 3 = 300
  for (double v : {0.5, 0.7, 0.9}) big.add_bm(v);
  big.add_che(0.0);
  pb::ExportProfilesRequest small;
  small.set_maps_file("maps.exr");
  small.add_cm(0.05), small.add_ch(0.05), small.add_bm(0.7), small.add_che(0.0);
  // The big one (300 profiles, ~15 s) is abandoned by its 5 s deadline. While
  // a small one below holds the only slot it is refused: it tries again.
  std::thread abandoned([&] {
    grpc::Status status;
    for (const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
         std::chrono::steady_clock::now() < until;) {
      grpc::ClientContext context;
      context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
      pb::ExportProfilesResponse response;
      status = stub->ExportProfiles(&context, big, &response);
      if (status.error_code() != grpc::StatusCode::RESOURCE_EXHAUSTED) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << status.error_message();
  });
  // Once the big one runs, the small one is refused. Until it has taken the
  // slot (a loaded machine may take a while to start it), the small one is
  // served: those are counted, not failed, and 300 ms pass before the next
  // so that the big one's retries find the slot free.
  int served_before = 0;
  grpc::Status refused;
  for (const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
       std::chrono::steady_clock::now() < until;) {
    grpc::ClientContext context;
    pb::ExportProfilesResponse response;
    refused = stub->ExportProfiles(&context, small, &response);
    if (!refused.ok()) break;
    ++served_before;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_THAT(refused.error_message(), HasSubstr("max_profile_exports"));
  abandoned.join();
  // The abandoned export stops at its next profile and gives its slot back:
  // the small one is served within a few tries (one that went on would hold
  // the slot ~10 s more on an idle machine; tries span up to 5 s, for a loaded one).
  grpc::Status status;
  pb::ExportProfilesResponse response;
  for (int i = 0; i < 16; ++i) {
    grpc::ClientContext context;
    status = stub->ExportProfiles(&context, small, &response);
    if (status.error_code() != grpc::StatusCode::RESOURCE_EXHAUSTED) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.entries(), 1u);
  // Only the small export's folder: the abandoned one wrote nothing.
  int folders = 0;
  for (const auto& entry : fs::directory_iterator(data / "products"))
    folders += entry.path().filename().string().rfind("profiles-", 0) == 0 && fs::exists(entry.path() / "index.exr");
  EXPECT_EQ(folders, 1 + served_before);
}

// GetMap: each output cell is the map's value at the cell's centre (the web
// view shows the value under the cursor); NaN stays NaN; bad requests name the field.
TEST_F(MapsApi, GetMapSamplesAChannelAtCellCentresAndRefusesBadRequests) {
  const int w = 48, h = 32;
  std::vector<float> cm(static_cast<std::size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) cm[static_cast<std::size_t>(y) * w + x] = 0.01f + 0.001f * x + 0.0001f * y;
  cm[static_cast<std::size_t>(3) * w + 5] = std::numeric_limits<float>::quiet_NaN();  // map cell (2, 1)'s centre
  files::write_exr(data / "gradient.exr", files::FloatImage{w, h, {"Cm", "flags"}, {cm, std::vector<float>(cm.size(), 0.0f)}});
  auto get = [&](const std::string& file, const std::string& channel, std::uint32_t max_width, pb::GetMapResponse* out) {
    grpc::ClientContext context;
    pb::GetMapRequest request;
    request.set_maps_file(file), request.set_channel(channel), request.set_max_width(max_width);
    return stub->GetMap(&context, request, out);
  };
  pb::GetMapResponse map;
  const grpc::Status got = get("gradient.exr", "Cm", 24, &map);
  ASSERT_TRUE(got.ok()) << got.error_code() << " " << got.error_message();
  EXPECT_EQ(map.width(), 24u);
  EXPECT_EQ(map.height(), 16u);
  EXPECT_EQ(map.source_width(), 48u);
  EXPECT_THAT(std::vector<std::string>(map.channels().begin(), map.channels().end()), ::testing::ElementsAre("Cm", "flags"));
  ASSERT_EQ(map.values_size(), 24 * 16);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 24; ++x) {
      const float v = map.values(y * 24 + x);
      if (x == 2 && y == 1) {
        EXPECT_TRUE(std::isnan(v));
        continue;
      }
      EXPECT_FLOAT_EQ(v, 0.01f + 0.001f * (2 * x + 1) + 0.0001f * (2 * y + 1)) << x << "," << y;
    }
  EXPECT_FLOAT_EQ(map.min(), 0.01f + 0.001f + 0.0001f);
  EXPECT_FLOAT_EQ(map.max(), 0.01f + 0.001f * 47 + 0.0001f * 31);
  pb::GetMapResponse small;  // never upscaled
  ASSERT_TRUE(get("gradient.exr", "flags", 1024, &small).ok());
  EXPECT_EQ(small.width(), 48u);
  // The decoded file is kept between calls and decoded again when it changes.
  std::vector<float> doubled(cm.size());
  for (std::size_t i = 0; i < cm.size(); ++i) doubled[i] = 2 * cm[i];
  files::write_exr(data / "gradient.tmp.exr", files::FloatImage{w, h, {"Cm", "flags"}, {doubled, std::vector<float>(cm.size(), 0.0f)}});
  std::filesystem::rename(data / "gradient.tmp.exr", data / "gradient.exr");
  pb::GetMapResponse changed;
  ASSERT_TRUE(get("gradient.exr", "Cm", 24, &changed).ok());
  EXPECT_FLOAT_EQ(changed.max(), 2 * map.max());
  files::write_exr(data / "gradient.exr", files::FloatImage{w, h, {"Cm", "flags"}, {cm, std::vector<float>(cm.size(), 0.0f)}});

  pb::GetMapResponse refused;
  grpc::Status s = get("gradient.exr", "Hb", 0, &refused);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("channel: \"Hb\" is not in the file (it has Cm, flags)"));
  s = get("gradient.exr", "Cm", 8, &refused);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("max_width"));
  s = get("../outside.exr", "Cm", 0, &refused);
  EXPECT_NE(s.error_code(), grpc::StatusCode::OK);
  EXPECT_THAT(s.error_message(), HasSubstr("maps_file"));
  // Issue 40, row 15: a file that is not an EXR answered INTERNAL.
  std::ofstream(data / "not-an-exr.exr") << "plain text, not OpenEXR";
  s = get("not-an-exr.exr", "Cm", 0, &refused);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_THAT(s.error_message(), HasSubstr("maps_file: "));
}

// GetRegionStatistics: the library's numbers over the file at full
// resolution (the web view's region statistics); GetMap says how to read
// the channel; bad regions refused naming the field.
// CompareSessions (issue 42 part 3 over the API): two maps files with
// Gaussian noise (σ 0.04 per pixel, a fifth of what their σ maps say), the
// after one with Ch × 1.5 (0.02 → 0.03) in a 36×28 rectangle: per pixel
// nothing stands out, the rectangle's median difference does and a
// rectangle elsewhere does not; its statistics are GetRegionStatistics' of
// each file; bad requests name their field.
TEST_F(MapsApi, CompareSessionsFindsARegionsChangeAgainstItsNoise) {
  const int w = 96, h = 72;
  std::mt19937 random(7);
  std::normal_distribution<float> noise(0.0f, 0.04f);
  auto maps_with = [&](double factor) {
    std::vector<float> ch(static_cast<std::size_t>(w) * h), sigma(ch.size(), 0.2f), cm(ch.size(), 0.05f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const bool flushed = x >= 6 && x < 42 && y >= 6 && y < 34;
        ch[static_cast<std::size_t>(y) * w + x] = static_cast<float>(0.02 * (flushed ? factor : 1.0)) + noise(random);
      }
    return files::FloatImage{w, h, {"Cm", "Ch", "sigma_Ch", "flags"}, {cm, ch, sigma, std::vector<float>(ch.size(), 0.0f)}};
  };
  const files::FloatImage before_maps = maps_with(1.0), after_maps = maps_with(1.5);
  files::write_exr(data / "before.exr", before_maps);
  files::write_exr(data / "after.exr", after_maps);
  auto compare = [&](const std::string& after_file, pb::MapRegion region, pb::CompareSessionsResponse* out,
                     std::uint32_t map_max_width = 0) {
    grpc::ClientContext context;
    pb::CompareSessionsRequest request;
    request.set_maps_file("before.exr"), request.set_after_maps_file(after_file), request.set_channel("Ch");
    request.set_no_registration(true), request.set_map_max_width(map_max_width);
    if (region.width() > 0) *request.mutable_region() = region;
    return stub->CompareSessions(&context, request, out);
  };
  pb::MapRegion flushed, elsewhere;
  flushed.set_x(6), flushed.set_y(6), flushed.set_width(36), flushed.set_height(28);
  elsewhere.set_x(50), elsewhere.set_y(36), elsewhere.set_width(36), elsewhere.set_height(28);
  pb::CompareSessionsResponse found, quiet, refused_map;
  const grpc::Status status = compare("after.exr", flushed, &found, 48);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_TRUE(compare("after.exr", elsewhere, &quiet).ok());
  std::cout << "CompareSessions: flushed median difference " << found.median_difference() << " sigma "
            << found.sigma_of_median() << " z " << found.z() << "; elsewhere z " << quiet.z() << "; per pixel "
            << found.significant_pixels() << " of " << found.compared_pixels() << " beyond 3 sigma\n";
  EXPECT_EQ(found.compared_pixels(), static_cast<std::uint64_t>(w * h));
  EXPECT_EQ(found.significant_pixels(), 0u);  // the σ maps' 0.2 per pixel hide a 0.01 change
  EXPECT_EQ(found.region_compared_pixels(), 36u * 28u);
  EXPECT_NEAR(found.median_difference(), 0.01, 0.005);
  EXPECT_NEAR(found.sigma_of_median(), 1.2533 * std::sqrt(2.0) * 0.04 / std::sqrt(36.0 * 28), 0.0004);
  EXPECT_TRUE(found.significant());
  EXPECT_GT(found.z(), 3);
  EXPECT_FALSE(quiet.significant());
  EXPECT_LT(std::abs(quiet.z()), 3);
  EXPECT_FALSE(found.warped());
  pb::GetRegionStatisticsResponse after_alone;
  {
    grpc::ClientContext context;
    pb::GetRegionStatisticsRequest request;
    request.set_maps_file("after.exr"), request.set_channel("Ch");
    *request.mutable_region() = flushed;
    ASSERT_TRUE(stub->GetRegionStatistics(&context, request, &after_alone).ok());
  }
  EXPECT_DOUBLE_EQ(found.after().mean(), after_alone.mean());
  EXPECT_DOUBLE_EQ(found.after().median(), after_alone.median());
  EXPECT_NEAR(found.after().median() / found.before().median(), 1.5, 0.3);
  // The difference map for display (the web view's before/after): 48 of 96
  // columns, each cell the pixel at its centre, as GetMap samples.
  ASSERT_EQ(found.map_width(), 48u);
  ASSERT_EQ(found.map_height(), 36u);
  const auto floats = [](const std::string& bytes) {
    std::vector<float> v(bytes.size() / sizeof(float));
    std::memcpy(v.data(), bytes.data(), v.size() * sizeof(float));
    return v;
  };
  const std::vector<float> difference = floats(found.difference_f32()), sigma = floats(found.sigma_f32()), z = floats(found.z_f32());
  ASSERT_EQ(difference.size(), 48u * 36u);
  ASSERT_EQ(sigma.size(), difference.size());
  ASSERT_EQ(z.size(), difference.size());
  for (const auto [cx, cy] : {std::pair{0, 0}, std::pair{10, 7}, std::pair{47, 35}}) {
    const std::size_t cell = static_cast<std::size_t>(cy) * 48 + cx;
    const std::size_t pixel = static_cast<std::size_t>(2 * cy + 1) * w + (2 * cx + 1);  // the cell's centre pixel
    const float expected = after_maps.channels[1][pixel] - before_maps.channels[1][pixel];
    EXPECT_FLOAT_EQ(difference[cell], expected) << "cell " << cx << "," << cy;
    EXPECT_FLOAT_EQ(sigma[cell], std::sqrt(0.2f * 0.2f * 2));
    EXPECT_NEAR(z[cell], expected / sigma[cell], 1e-5);
  }
  EXPECT_TRUE(quiet.difference_f32().empty());  // no map asked for
  grpc::Status too_narrow = compare("after.exr", flushed, &refused_map, 8);
  EXPECT_EQ(too_narrow.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(too_narrow.error_message(), HasSubstr("map_max_width: must be 16-1024"));

  pb::CompareSessionsResponse refused;
  grpc::Status s = compare("missing.exr", flushed, &refused);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("after_maps_file: missing.exr: no such file"));
  pb::MapRegion outside = flushed;
  outside.set_x(80);
  s = compare("after.exr", outside, &refused);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("region"));
  s = compare("after.exr", pb::MapRegion(), &refused);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("region: required"));
}

TEST_F(MapsApi, RegionStatisticsAreTheFilesAndGetMapGivesUnitAndModelRange) {
  const int w = 40, h = 30;
  std::vector<float> cm(static_cast<std::size_t>(w) * h), flags(cm.size(), 0.0f);
  for (std::size_t i = 0; i < cm.size(); ++i) cm[i] = 0.02f + 0.0003f * static_cast<float>(i % 97);
  flags[5 * w + 7] = 3;  // dark: masked
  files::FloatImage image{w, h, {"Cm", "flags"}, {cm, flags}};
  files::write_exr(data / "region.exr", image);
  grpc::ClientContext context;
  pb::GetRegionStatisticsRequest request;
  request.set_maps_file("region.exr"), request.set_channel("Cm");
  auto* region = request.mutable_region();
  region->set_x(3), region->set_y(2), region->set_width(20), region->set_height(11);
  pb::GetRegionStatisticsResponse reply;
  const grpc::Status got = stub->GetRegionStatistics(&context, request, &reply);
  ASSERT_TRUE(got.ok()) << got.error_message();
  const maps::RegionStatistics expected = maps::region_statistics(image, "Cm", {3, 2, 20, 11});
  EXPECT_EQ(reply.pixels(), 219u);
  EXPECT_EQ(reply.flagged_pixels(), 1u);
  EXPECT_EQ(reply.unit(), "volume fraction");
  EXPECT_DOUBLE_EQ(reply.mean(), expected.mean);
  EXPECT_DOUBLE_EQ(reply.sd(), expected.sd);
  EXPECT_DOUBLE_EQ(reply.p5(), expected.p5);
  EXPECT_DOUBLE_EQ(reply.p95(), expected.p95);
  EXPECT_EQ(reply.source_width(), 40u);

  auto refused = [&](const std::function<void(pb::GetRegionStatisticsRequest&)>& edit) {
    grpc::ClientContext c;
    pb::GetRegionStatisticsRequest bad = request;
    edit(bad);
    pb::GetRegionStatisticsResponse out;
    const grpc::Status s = stub->GetRegionStatistics(&c, bad, &out);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    return s.error_message();
  };
  EXPECT_THAT(refused([](auto& r) { r.clear_region(); }), HasSubstr("region: required"));
  EXPECT_THAT(refused([](auto& r) { r.mutable_region()->set_x(30); }), HasSubstr("region: 30,2 20×11 is not inside the 40×30 map"));
  EXPECT_THAT(refused([](auto& r) { r.mutable_region()->set_height(0); }), HasSubstr("region: "));
  EXPECT_THAT(refused([](auto& r) { r.set_channel("Hb"); }), HasSubstr("channel: \"Hb\""));
  EXPECT_THAT(refused([](auto& r) { r.set_maps_file("../region.exr"); }), HasSubstr("maps_file"));

  grpc::ClientContext map_context;
  pb::GetMapRequest map_request;
  map_request.set_maps_file("region.exr"), map_request.set_channel("Cm");
  pb::GetMapResponse map;
  ASSERT_TRUE(stub->GetMap(&map_context, map_request, &map).ok());
  EXPECT_EQ(map.unit(), "volume fraction");
  EXPECT_DOUBLE_EQ(map.model_min(), 0.001);
  EXPECT_DOUBLE_EQ(map.model_max(), 0.5);
  EXPECT_TRUE(map.log_scale());
  ASSERT_EQ(map.flag_names_size(), 10);
  EXPECT_EQ(map.flag_names(9), "white_target");
  EXPECT_EQ(map.flag_names(3), "dark");
  EXPECT_EQ(map.sigma_values_size(), 0);  // the file has no sigma_Cm
  std::vector<float> sigma(cm.size());
  for (std::size_t i = 0; i < sigma.size(); ++i) sigma[i] = 0.001f * static_cast<float>(i);
  files::write_exr(data / "sigma.exr", files::FloatImage{w, h, {"Cm", "sigma_Cm"}, {cm, sigma}});
  grpc::ClientContext sigma_context;
  map_request.set_maps_file("sigma.exr"), map_request.set_max_width(20);
  pb::GetMapResponse with_sigma;
  ASSERT_TRUE(stub->GetMap(&sigma_context, map_request, &with_sigma).ok());
  ASSERT_EQ(with_sigma.sigma_values_size(), 20 * 15);
  EXPECT_FLOAT_EQ(with_sigma.sigma_values(2 * 20 + 3), sigma[5 * w + 7]);  // cell (3, 2)'s centre: pixel (7, 5)
  EXPECT_FLOAT_EQ(with_sigma.values(2 * 20 + 3), cm[5 * w + 7]);
  // packed: the same floats as little-endian bytes, the repeated fields empty.
  grpc::ClientContext packed_context;
  map_request.set_packed(true);
  pb::GetMapResponse packed;
  ASSERT_TRUE(stub->GetMap(&packed_context, map_request, &packed).ok());
  EXPECT_EQ(packed.values_size(), 0);
  ASSERT_EQ(packed.values_f32().size(), 20u * 15u * sizeof(float));
  ASSERT_EQ(packed.sigma_f32().size(), 20u * 15u * sizeof(float));
  std::vector<float> unpacked(20 * 15), unpacked_sigma(20 * 15);
  std::memcpy(unpacked.data(), packed.values_f32().data(), packed.values_f32().size());
  std::memcpy(unpacked_sigma.data(), packed.sigma_f32().data(), packed.sigma_f32().size());
  for (int i = 0; i < 20 * 15; ++i) {
    EXPECT_EQ(unpacked[i], with_sigma.values(i));
    EXPECT_EQ(unpacked_sigma[i], with_sigma.sigma_values(i));
  }
}

TEST_F(MapsApi, ImportMapsGivesTheTableTwoComparison) {
  simulators::ExternalMapsSceneOptions scene;
  scene.width = 48, scene.height = 36;
  simulators::write_external_maps_scene(data / "scene", scene);
  ::setenv("CHROMO_CACHE_DIR", (lab.directory / "cache").c_str(), 1);
  grpc::ClientContext context;
  pb::ImportMapsRequest request;
  request.set_melanin_file("scene/melanin.png");
  request.set_hemoglobin_file("scene/hemoglobin.png");
  request.set_measurement_file("scene/MEASUREMENT.json");
  pb::ImportMapsResponse response;
  const grpc::Status status = stub->ImportMaps(&context, request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_GT(response.mapped_2d().mean(), response.augmented().mean());
  EXPECT_GT(response.augmented().mean(), response.search_4d().mean());
  EXPECT_TRUE(response.melanin_increasing());
  EXPECT_THAT(response.out_dir(), StartsWith("products/import-maps-"));
  EXPECT_TRUE(fs::exists(data / response.out_dir() / "comparison.json"));
}

TEST_F(MapsApi, HostileRequestsAreRefusedWithTheFieldNamed) {
  auto relight = [&](const pb::RelightRequest& request) {
    grpc::ClientContext context;
    pb::RelightResponse response;
    return stub->Relight(&context, request, &response);
  };
  pb::RelightRequest good;
  good.set_maps_file("maps.exr");
  good.set_illuminant("D65");
  struct Case {
    std::function<void(pb::RelightRequest&)> change;
    grpc::StatusCode code;
    std::string field;
  };
  const std::vector<Case> cases{
      {[](auto& r) { r.clear_maps_file(); }, grpc::StatusCode::INVALID_ARGUMENT, "maps_file: required"},
      {[&](auto& r) { r.set_maps_file((data / "maps.exr").string()); }, grpc::StatusCode::INVALID_ARGUMENT,
       "maps_file: must be a path relative to maps_dir, not absolute"},
      {[](auto& r) { r.set_maps_file("missing.exr"); }, grpc::StatusCode::INVALID_ARGUMENT, "maps_file: missing.exr: no such file"},
      {[](auto& r) { r.set_maps_file("."); }, grpc::StatusCode::INVALID_ARGUMENT, "maps_file: .: not a regular file"},
      {[](auto& r) { r.set_maps_file("../maps-work/maps.exr"); }, grpc::StatusCode::INVALID_ARGUMENT, "maps_file: must not contain"},
      {[](auto& r) { r.set_illuminant("D66"); }, grpc::StatusCode::INVALID_ARGUMENT, "illuminant: "},
      {[](auto& r) { r.clear_illuminant(); }, grpc::StatusCode::INVALID_ARGUMENT, "illuminant: required"},
      {[](auto& r) { r.set_label("."); }, grpc::StatusCode::INVALID_ARGUMENT, "label: must match"},
      {[](auto& r) { r.set_label("frames/dark"); }, grpc::StatusCode::INVALID_ARGUMENT, "label: must match"},
      {[](auto& r) { r.set_label(std::string(5000, 'x')); }, grpc::StatusCode::INVALID_ARGUMENT, "label: must match"},
      {[](auto& r) { r.set_illuminant("/dev/zero"); }, grpc::StatusCode::INVALID_ARGUMENT, "illuminant: must be a path relative"},
      {[](auto& r) { r.set_camera("/etc/passwd"); }, grpc::StatusCode::INVALID_ARGUMENT, "camera: must be a path relative"},
      {[](auto& r) { r.set_session_id("no-such-session"); }, grpc::StatusCode::NOT_FOUND, "session_id: "},
      {[](auto& r) { r.set_session_id("../etc"); }, grpc::StatusCode::INVALID_ARGUMENT, "session_id: "},
      {[&](auto& r) { r.set_photograph_file("maps.exr"); }, grpc::StatusCode::INVALID_ARGUMENT, "photograph_file: "},
      {[](auto& r) { r.set_heat_map_max(-1); }, grpc::StatusCode::INVALID_ARGUMENT, "heat_map_max: "},
  };
  for (const Case& c : cases) {
    pb::RelightRequest request = good;
    c.change(request);
    const grpc::Status status = relight(request);
    EXPECT_EQ(status.error_code(), c.code) << c.field << ": " << status.error_message();
    EXPECT_THAT(status.error_message(), StartsWith(c.field));
    EXPECT_THAT(status.error_message(), Not(HasSubstr(lab.directory.string()))) << c.field;
    EXPECT_FALSE(fs::exists(data / "products")) << c.field;
  }
  // Flush: a region outside the image, no region, a mask of another size.
  grpc::ClientContext context;
  pb::FlushRequest flush;
  flush.set_maps_file("maps.exr");
  flush.mutable_scale()->set_ch(1.5);
  auto* e = flush.mutable_ellipse();
  e->set_center_x_px(-100), e->set_center_y_px(-100), e->set_radius_x_px(5), e->set_radius_y_px(5);
  pb::FlushResponse response;
  grpc::Status status = stub->Flush(&context, flush, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), StartsWith("ellipse: "));
  flush.clear_ellipse();
  grpc::ClientContext context2;
  status = stub->Flush(&context2, flush, &response);
  EXPECT_THAT(status.error_message(), StartsWith("region: "));
  flush.mutable_scale()->set_che(-2);
  flush.set_mask_file("maps.exr");
  grpc::ClientContext context3;
  status = stub->Flush(&context3, flush, &response);
  EXPECT_THAT(status.error_message(), StartsWith("scale.che: "));
  // Import: the 4D search is "fast" or "exhaustive"; the 2D inverter is no 4D search.
  for (const char* search : {"2d", "kd-tree"}) {
    grpc::ClientContext import_context;
    pb::ImportMapsRequest import;
    import.set_search_4d(search);
    pb::ImportMapsResponse import_response;
    status = stub->ImportMaps(&import_context, import, &import_response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << search;
    EXPECT_THAT(status.error_message(), StartsWith("search_4d: ")) << search;
  }
  EXPECT_FALSE(fs::exists(data / "products"));
}

// Every file under `folder` (recursively) with its bytes.
std::map<std::string, std::string> snapshot(const fs::path& folder) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    files[entry.path().lexically_relative(folder).string()] =
        std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return files;
}

TEST_F(MapsApi, ASessionsResultsAndFramesAreNeverWrittenAndNothingOutsideIsRead) {
  const auto started = daemon->start_session(testing::quick_standard_plan(), "maps api");
  const auto ended = testing::wait_final(*daemon, started.id);
  ASSERT_EQ(ended.state, session::OperationState::kSucceeded) << ended.error;
  const fs::path folder = lab.config.sessions_dir / started.id;
  // Without an LED library (no calibration run here) the estimator may
  // publish no maps; then published maps are put in place as the estimator
  // leaves them (results/maps.exr).
  if (!fs::exists(folder / "results" / "maps.exr")) {
    fs::create_directories(folder / "results");
    fs::copy_file(data / "maps.exr", folder / "results" / "maps.exr");
  }
  // Planted by someone with a shell: links out of the session folder.
  fs::create_symlink("/root/.ssh/id_rsa", folder / "key.exr");
  fs::create_symlink("/etc/shadow", folder / "shadow.exr");
  fs::create_symlink("/dev/zero", folder / "zero.csv");
  fs::create_symlink("/etc", folder / "etc");
  const auto results_before = snapshot(folder / "results");
  const auto frames_before = snapshot(folder / "frames");
  ASSERT_GT(frames_before.size(), 6u);

  // The reproduced data loss: Flush(maps_file results/maps.exr, out_dir results).
  grpc::ClientContext flush_context;
  pb::FlushRequest flush;
  flush.set_session_id(started.id);
  flush.set_maps_file("results/maps.exr");
  flush.set_label("results");
  flush.mutable_scale()->set_ch(1.5);
  auto* e = flush.mutable_ellipse();
  e->set_center_x_px(30), e->set_center_y_px(20), e->set_radius_x_px(10), e->set_radius_y_px(8);
  pb::FlushResponse flushed;
  const grpc::Status flush_status = stub->Flush(&flush_context, flush, &flushed);
  ASSERT_TRUE(flush_status.ok()) << flush_status.error_message();
  EXPECT_THAT(flushed.out_dir(), ::testing::MatchesRegex("products/flush-[0-9]{8}T[0-9]{6}Z-[0-9a-f]{6}-results"));
  EXPECT_TRUE(fs::exists(folder / flushed.out_dir() / "maps.exr"));

  auto relight = [&](const std::function<void(pb::RelightRequest&)>& change) {
    pb::RelightRequest request;
    request.set_session_id(started.id);
    request.set_maps_file("results/maps.exr");
    request.set_illuminant("W27");
    change(request);
    grpc::ClientContext context;
    pb::RelightResponse response;
    const grpc::Status status = stub->Relight(&context, request, &response);
    return std::make_pair(status, response);
  };
  // Relit from the session's maps into products/, never into frames/.
  const auto [ok, relit] = relight([](auto&) {});
  ASSERT_TRUE(ok.ok()) << ok.error_message();
  EXPECT_THAT(relit.out_dir(), StartsWith("products/relight-"));
  // Flagged pixels (dark, saturated) are not relit: most of the maps are.
  EXPECT_GT(relit.relit_pixels(), 0.9 * relit.width() * relit.height());
  struct Case {
    std::function<void(pb::RelightRequest&)> change;
    std::string message;
  };
  const std::vector<Case> refused{
      {[](auto& r) { r.set_label("."); }, "label: must match [A-Za-z0-9_+.-]{1,64}"},
      {[](auto& r) { r.set_label("frames/dark"); }, "label: must match [A-Za-z0-9_+.-]{1,64}"},
      {[](auto& r) { r.set_maps_file("/etc/shadow"); }, "maps_file: must be a path relative to the session folder, not absolute"},
      {[](auto& r) { r.set_maps_file("/root/.ssh/id_rsa"); }, "maps_file: must be a path relative to the session folder, not absolute"},
      // A missing and an unreadable target outside read the same.
      {[](auto& r) { r.set_maps_file("key.exr"); }, "maps_file: key.exr leads outside the session folder"},
      {[](auto& r) { r.set_maps_file("shadow.exr"); }, "maps_file: shadow.exr leads outside the session folder"},
      {[](auto& r) { r.set_maps_file("etc/shadow"); }, "maps_file: etc/shadow leads outside the session folder"},
      {[](auto& r) { r.set_maps_file("etc/no-such-file"); }, "maps_file: etc/no-such-file leads outside the session folder"},
      {[](auto& r) { r.set_illuminant("zero.csv"); }, "illuminant: zero.csv leads outside the session folder"},
      {[](auto& r) { r.set_illuminant("/dev/zero"); }, "illuminant: must be a path relative to the session folder, not absolute"},
      {[](auto& r) { r.set_maps_file("frames"); }, "maps_file: frames: not a regular file"},
      {[](auto& r) { r.set_maps_file("results/../../x"); }, "maps_file: must not contain \"..\""},
  };
  for (const Case& c : refused) {
    const auto [status, response] = relight(c.change);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.message;
    EXPECT_EQ(status.error_message(), c.message);
  }
  // A library error names the file relative to the session folder.
  const auto [bad_maps, unused] = relight([](auto& r) { r.set_maps_file("session.json"); });
  EXPECT_EQ(bad_maps.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(bad_maps.error_message(), StartsWith("maps_file: "));
  EXPECT_THAT(bad_maps.error_message(), Not(HasSubstr(lab.directory.string())));

  EXPECT_EQ(snapshot(folder / "results"), results_before);
  EXPECT_EQ(snapshot(folder / "frames"), frames_before);
  // Two products, nothing else new in the session folder's top level.
  std::set<std::string> products;
  for (const auto& entry : fs::directory_iterator(folder / "products")) products.insert(entry.path().filename().string());
  EXPECT_EQ(products.size(), 2u);
}

TEST(MapsApiWithoutMapsDir, CallsWithoutASessionAreRefused) {
  testing::TestLab lab{"maps-api-no-dir"};
  auto daemon = lab.daemon();
  Server server(*daemon);
  auto stub = pb::MapsService::NewStub(grpc::CreateChannel("unix:" + lab.config.unix_socket, grpc::InsecureChannelCredentials()));
  for (const char* path : {"/etc/shadow", "/root/.ssh/id_rsa", "maps.exr"}) {
    grpc::ClientContext context;
    pb::RelightRequest request;
    request.set_maps_file(path);
    request.set_illuminant("D65");
    pb::RelightResponse response;
    const grpc::Status status = stub->Relight(&context, request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_EQ(status.error_message(), "session_id: required (this daemon has no maps_dir for work without a session)");
  }
  server.shutdown();
}

}  // namespace
}  // namespace chromo::daemon
