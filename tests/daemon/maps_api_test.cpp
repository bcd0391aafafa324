// The Maps service (proto/chromosphere/v1/maps.proto) over a real gRPC Unix
// socket: each call on real files, and hostile requests refused with the
// field named and nothing written.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <grpcpp/grpcpp.h>

#include "chromo/daemon/server.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/simulators/scene/external_maps_scene.hpp"
#include "chromosphere/v1/maps.grpc.pb.h"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;
namespace pb = chromosphere::v1;
using ::testing::HasSubstr;
using ::testing::StartsWith;

struct MapsApi : ::testing::Test {
  testing::TestLab lab{"maps-api"};
  std::unique_ptr<Daemon> daemon;
  std::unique_ptr<Server> server;
  std::unique_ptr<pb::MapsService::Stub> stub;
  fs::path data;

  void SetUp() override {
    daemon = lab.daemon();
    server = std::make_unique<Server>(*daemon);
    stub = pb::MapsService::NewStub(
        grpc::CreateChannel("unix:" + lab.config.unix_socket, grpc::InsecureChannelCredentials()));
    data = lab.directory / "data";
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
    request.set_maps_file((data / "maps.exr").string());
    request.set_illuminant("4000K");
    request.set_out_dir((data / "relit").string());
    pb::RelightResponse response;
    const grpc::Status status = stub->Relight(&context, request, &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(response.relit_pixels(), 24u * 16u);
    EXPECT_EQ(response.illuminant(), "4000K");
    EXPECT_TRUE(fs::exists(data / "relit" / "relit.exr"));
    EXPECT_THAT(response.summary_json(), HasSubstr("\"relit_pixels\": 384"));
  }
  {
    grpc::ClientContext context;
    pb::FlushRequest request;
    request.set_maps_file((data / "maps.exr").string());
    request.mutable_scale()->set_ch(10);  // 0.4 > 0.32: clamped
    auto* e = request.mutable_ellipse();
    e->set_center_x_px(12), e->set_center_y_px(8), e->set_radius_x_px(6), e->set_radius_y_px(4);
    request.set_out_dir((data / "flushed").string());
    pb::FlushResponse response;
    const grpc::Status status = stub->Flush(&context, request, &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_GT(response.pixels_touched(), 50u);
    EXPECT_DOUBLE_EQ(response.clamped_share(), 0.25);
    EXPECT_TRUE(fs::exists(data / "flushed" / "panel.png"));
  }
  {
    grpc::ClientContext context;
    pb::ExportProfilesRequest request;
    request.set_out_dir((data / "profiles").string());
    request.set_maps_file((data / "maps.exr").string());
    for (double v : {0.01, 0.1}) request.add_cm(v), request.add_ch(v);
    request.add_bm(0.7), request.add_che(0.0);
    pb::ExportProfilesResponse response;
    const grpc::Status status = stub->ExportProfiles(&context, request, &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(response.entries(), 4u);
    EXPECT_LT(response.worst_plane_integral_error(), 0.005);
    EXPECT_TRUE(fs::exists(data / "profiles" / "index.exr"));
  }
}

TEST_F(MapsApi, ImportMapsGivesTheTableTwoComparison) {
  simulators::ExternalMapsSceneOptions scene;
  scene.width = 48, scene.height = 36;
  simulators::write_external_maps_scene(data / "scene", scene);
  ::setenv("CHROMO_CACHE_DIR", (lab.directory / "cache").c_str(), 1);
  grpc::ClientContext context;
  pb::ImportMapsRequest request;
  request.set_melanin_file((data / "scene" / "melanin.png").string());
  request.set_hemoglobin_file((data / "scene" / "hemoglobin.png").string());
  request.set_measurement_file((data / "scene" / "MEASUREMENT.json").string());
  request.set_out_dir((data / "imported").string());
  pb::ImportMapsResponse response;
  const grpc::Status status = stub->ImportMaps(&context, request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_GT(response.mapped_2d().mean(), response.augmented().mean());
  EXPECT_GT(response.augmented().mean(), response.search_4d().mean());
  EXPECT_TRUE(response.melanin_increasing());
  EXPECT_TRUE(fs::exists(data / "imported" / "comparison.json"));
}

TEST_F(MapsApi, HostileRequestsAreRefusedWithTheFieldNamed) {
  auto relight = [&](const pb::RelightRequest& request) {
    grpc::ClientContext context;
    pb::RelightResponse response;
    return stub->Relight(&context, request, &response);
  };
  pb::RelightRequest good;
  good.set_maps_file((data / "maps.exr").string());
  good.set_illuminant("D65");
  good.set_out_dir((data / "out").string());
  struct Case {
    std::function<void(pb::RelightRequest&)> change;
    grpc::StatusCode code;
    std::string field;
  };
  const std::vector<Case> cases{
      {[](auto& r) { r.clear_maps_file(); }, grpc::StatusCode::INVALID_ARGUMENT, "maps_file: required"},
      {[](auto& r) { r.set_maps_file("relative/maps.exr"); }, grpc::StatusCode::INVALID_ARGUMENT, "maps_file: must be an absolute"},
      {[&](auto& r) { r.set_maps_file((data / "missing.exr").string()); }, grpc::StatusCode::INVALID_ARGUMENT, "maps_file: "},
      {[](auto& r) { r.set_illuminant("D66"); }, grpc::StatusCode::INVALID_ARGUMENT, "illuminant: "},
      {[](auto& r) { r.clear_illuminant(); }, grpc::StatusCode::INVALID_ARGUMENT, "illuminant: required"},
      {[](auto& r) { r.clear_out_dir(); }, grpc::StatusCode::INVALID_ARGUMENT, "out_dir: required"},
      {[](auto& r) { r.set_out_dir(std::string(5000, 'x')); }, grpc::StatusCode::INVALID_ARGUMENT, "out_dir: longer"},
      {[](auto& r) { r.set_session_id("no-such-session"); }, grpc::StatusCode::NOT_FOUND, "session_id: "},
      {[](auto& r) { r.set_session_id("../etc"); }, grpc::StatusCode::INVALID_ARGUMENT, "session_id: "},
      {[&](auto& r) { r.set_photograph_file((data / "maps.exr").string()); }, grpc::StatusCode::INVALID_ARGUMENT,
       "photograph_file: "},
      {[](auto& r) { r.set_heat_map_max(-1); }, grpc::StatusCode::INVALID_ARGUMENT, "heat_map_max: "},
  };
  for (const Case& c : cases) {
    pb::RelightRequest request = good;
    c.change(request);
    const grpc::Status status = relight(request);
    EXPECT_EQ(status.error_code(), c.code) << c.field << ": " << status.error_message();
    EXPECT_THAT(status.error_message(), StartsWith(c.field));
    EXPECT_FALSE(fs::exists(data / "out")) << c.field;
  }
  // Flush: a region outside the image, no region, a mask of another size.
  grpc::ClientContext context;
  pb::FlushRequest flush;
  flush.set_maps_file((data / "maps.exr").string());
  flush.set_out_dir((data / "out").string());
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
  flush.set_mask_file((data / "maps.exr").string());
  grpc::ClientContext context3;
  status = stub->Flush(&context3, flush, &response);
  EXPECT_THAT(status.error_message(), StartsWith("scale.che: "));
  // Import: the 4D search is "fast" or "exhaustive"; the 2D inverter is no 4D search.
  for (const char* search : {"2d", "kd-tree"}) {
    grpc::ClientContext import_context;
    pb::ImportMapsRequest import;
    import.set_search_4d(search);
    import.set_out_dir((data / "out").string());
    pb::ImportMapsResponse import_response;
    status = stub->ImportMaps(&import_context, import, &import_response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << search;
    EXPECT_THAT(status.error_message(), StartsWith("search_4d: ")) << search;
  }
  EXPECT_FALSE(fs::exists(data / "out"));
}

}  // namespace
}  // namespace chromo::daemon
