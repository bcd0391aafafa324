// The operator's web view over real HTTP on loopback (daemon/include/chromo/
// daemon/web_server.hpp, docs/web.md): chromod's WebServer on the virtual
// lab's Daemon and gRPC Server, driven by cpp-httplib's client. Log-in and
// its cookie, the origin check, the security headers, static and session
// files kept inside their folders, the API bridge answering as the API does,
// bad JSON refused with nothing changed, the preview stream, and camera
// settings refused during a session.
#include <atomic>
#include <bitset>
#include <fstream>
#include <regex>
#include <thread>

#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>

#include "chromo/daemon/server.hpp"
#include "chromo/daemon/web_server.hpp"
#include "chromosphere/v1/leds.grpc.pb.h"
#include "test_lab.hpp"

// After every Eigen header: httplib.h includes <resolv.h>, whose `_res` macro
// would rename an Eigen parameter.
#include <httplib.h>

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;
namespace pb = chromosphere::v1;

constexpr const char* kWebToken = "web-test-token-0123456789";

// Protobuf JSON's bytes (standard base64) back to bytes.
std::string base64_decode(const std::string& text) {
  static const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  unsigned bits = 0;
  int count = 0;
  for (char c : text) {
    const auto value = alphabet.find(c);
    if (value == std::string::npos) continue;  // '=' padding
    bits = (bits << 6) | static_cast<unsigned>(value), count += 6;
    if (count >= 8) out.push_back(static_cast<char>((bits >> (count - 8)) & 0xff)), count -= 8;
  }
  return out;
}

struct WebFixture : ::testing::Test {
  testing::TestLab lab{"web"};
  std::unique_ptr<Daemon> daemon;
  std::unique_ptr<Server> server;
  std::unique_ptr<WebServer> web;
  std::string origin;

  void SetUp() override {
    lab.config.token = kWebToken;
    lab.config.web_address = "127.0.0.1:0";
    lab.config.web_dir = lab.directory / "www";
    fs::create_directories(lab.config.web_dir / "assets");
    std::ofstream(lab.config.web_dir / "index.html") << "<!doctype html><title>chromo</title>";
    std::ofstream(lab.config.web_dir / "assets" / "app.js") << "console.log('app');";
    std::ofstream(lab.config.web_dir / ".secret") << "hidden";
    std::ofstream(lab.directory / "outside.txt") << "outside the web folder";
    fs::create_symlink(lab.directory / "outside.txt", lab.config.web_dir / "link.txt");
    daemon = lab.daemon();
    server = std::make_unique<Server>(*daemon);
    web = std::make_unique<WebServer>(lab.config, server->in_process_channel(),
                                      [this](const std::string& who, const std::string& action, const std::string& error) {
                                        server->audit(who, action, error);
                                      });
    origin = "http://127.0.0.1:" + std::to_string(web->port());
  }
  void TearDown() override {
    if (web) web->stop();
    if (server) server->shutdown();
  }
  httplib::Client client() const {
    httplib::Client c("127.0.0.1", web->port());
    c.set_read_timeout(20, 0);
    return c;
  }
  // Logs in and returns the cookie header ("chromo_session=<id>").
  std::string log_in() {
    auto c = client();
    auto r = c.Post("/login", {{"Origin", origin}}, nlohmann::json{{"token", kWebToken}}.dump(), "application/json");
    EXPECT_TRUE(r);
    if (!r) return {};
    EXPECT_EQ(r->status, 200) << r->body;
    const std::string set_cookie = r->get_header_value("Set-Cookie");
    return set_cookie.substr(0, set_cookie.find(';'));
  }
  httplib::Result api(const std::string& cookie, const std::string& method, const std::string& body) {
    return client().Post(("/api/" + method).c_str(), {{"Origin", origin}, {"Cookie", cookie}}, body, "application/json");
  }
  std::vector<nlohmann::json> audit_lines() const {
    std::vector<nlohmann::json> lines;
    std::ifstream in(lab.config.sessions_dir / "audit.jsonl");
    for (std::string line; std::getline(in, line);) lines.push_back(nlohmann::json::parse(line));
    return lines;
  }
};

TEST_F(WebFixture, LogInSetsAStrictHttpOnlyCookieAndAWrongTokenIsRefusedAndAudited) {
  auto c = client();
  auto wrong = c.Post("/login", {{"Origin", origin}}, R"({"token":"not-the-token-at-all"})", "application/json");
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->status, 401);
  EXPECT_FALSE(wrong->has_header("Set-Cookie"));
  auto malformed = c.Post("/login", {{"Origin", origin}}, "token=x", "application/x-www-form-urlencoded");
  ASSERT_TRUE(malformed);
  EXPECT_EQ(malformed->status, 400);
  EXPECT_NE(malformed->body.find("token"), std::string::npos);

  auto right = c.Post("/login", {{"Origin", origin}}, nlohmann::json{{"token", kWebToken}}.dump(), "application/json");
  ASSERT_TRUE(right);
  ASSERT_EQ(right->status, 200);
  const std::string cookie = right->get_header_value("Set-Cookie");
  EXPECT_TRUE(std::regex_search(cookie, std::regex("^chromo_session=[0-9a-f]{64}; "))) << cookie;
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos);
  EXPECT_NE(cookie.find("SameSite=Strict"), std::string::npos);
  EXPECT_NE(cookie.find("Path=/"), std::string::npos);
  EXPECT_EQ(cookie.find("Secure"), std::string::npos);  // plain HTTP on loopback

  // Two log-ins, two different session ids.
  EXPECT_NE(log_in(), cookie.substr(0, cookie.find(';')));

  int failed = 0, succeeded = 0;
  for (const auto& line : audit_lines())
    if (line.value("action", "") == "web_login") (line.value("outcome", "") == "ok" ? succeeded : failed) += 1;
  EXPECT_EQ(failed, 1);
  EXPECT_EQ(succeeded, 2);
}

TEST_F(WebFixture, RepeatedWrongTokensAreLimitedPerClient) {
  auto c = client();
  for (int i = 0; i < kMaxFailedLogins; ++i) {
    auto r = c.Post("/login", {{"Origin", origin}}, R"({"token":"guess-guess-guess-guess"})", "application/json");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 401);
  }
  // Even the right token waits now: guessing costs a minute per five tries.
  auto limited = c.Post("/login", {{"Origin", origin}}, nlohmann::json{{"token", kWebToken}}.dump(), "application/json");
  ASSERT_TRUE(limited);
  EXPECT_EQ(limited->status, 429);
  EXPECT_TRUE(limited->has_header("Retry-After"));
  EXPECT_FALSE(limited->has_header("Set-Cookie"));
}

TEST_F(WebFixture, TheApiNeedsTheCookieAndThePagesOwnOrigin) {
  const std::string cookie = log_in();
  auto c = client();
  auto no_cookie = c.Post("/api/LedService/GetLedState", {{"Origin", origin}}, "{}", "application/json");
  ASSERT_TRUE(no_cookie);
  EXPECT_EQ(no_cookie->status, 401);
  auto forged = c.Post("/api/LedService/GetLedState", {{"Origin", origin}, {"Cookie", "chromo_session=" + std::string(64, 'a')}},
                       "{}", "application/json");
  ASSERT_TRUE(forged);
  EXPECT_EQ(forged->status, 401);
  auto cross = c.Post("/api/LedService/GetLedState", {{"Origin", "http://evil.example"}, {"Cookie", cookie}}, "{}",
                      "application/json");
  ASSERT_TRUE(cross);
  EXPECT_EQ(cross->status, 403);
  EXPECT_NE(cross->body.find("evil.example"), std::string::npos);
  auto no_origin = c.Post("/api/LedService/GetLedState", {{"Cookie", cookie}}, "{}", "application/json");
  ASSERT_TRUE(no_origin);
  EXPECT_EQ(no_origin->status, 403);
  auto cross_login = c.Post("/login", {{"Origin", "http://evil.example"}}, nlohmann::json{{"token", kWebToken}}.dump(),
                            "application/json");
  ASSERT_TRUE(cross_login);
  EXPECT_EQ(cross_login->status, 403);
  auto ok = api(cookie, "LedService/GetLedState", "{}");
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->status, 200) << ok->body;

  // Log-out ends the session id.
  auto out = c.Post("/logout", {{"Origin", origin}, {"Cookie", cookie}}, "", "text/plain");
  ASSERT_TRUE(out);
  EXPECT_NE(out->get_header_value("Set-Cookie").find("Max-Age=0"), std::string::npos);
  auto after = api(cookie, "LedService/GetLedState", "{}");
  ASSERT_TRUE(after);
  EXPECT_EQ(after->status, 401);
}

TEST_F(WebFixture, EveryResponseCarriesTheSecurityHeaders) {
  const std::string cookie = log_in();
  auto c = client();
  std::vector<httplib::Result> responses;
  responses.push_back(c.Get("/"));
  responses.push_back(c.Get("/no-such-page.html"));
  responses.push_back(c.Post("/api/LedService/GetLedState", {{"Origin", origin}}, "{}", "application/json"));
  responses.push_back(api(cookie, "LedService/GetLedState", "{}"));
  for (const auto& r : responses) {
    ASSERT_TRUE(r);
    const std::string csp = r->get_header_value("Content-Security-Policy");
    EXPECT_NE(csp.find("script-src 'self'"), std::string::npos) << r->status;
    EXPECT_EQ(csp.find("unsafe-inline"), std::string::npos);
    EXPECT_EQ(csp.find("unsafe-eval"), std::string::npos);
    EXPECT_EQ(r->get_header_value("Referrer-Policy"), "same-origin");
    EXPECT_EQ(r->get_header_value("X-Content-Type-Options"), "nosniff");
  }
}

TEST_F(WebFixture, StaticFilesStayInsideTheWebFolder) {
  auto c = client();
  auto index = c.Get("/");
  ASSERT_TRUE(index);
  EXPECT_EQ(index->status, 200);
  EXPECT_NE(index->body.find("<title>chromo</title>"), std::string::npos);
  auto script = c.Get("/assets/app.js");
  ASSERT_TRUE(script);
  EXPECT_EQ(script->status, 200);
  EXPECT_EQ(script->get_header_value("Content-Type").rfind("text/javascript", 0), 0u);
  for (const char* path : {"/../outside.txt", "/assets/../../outside.txt", "/%2e%2e/outside.txt", "/.secret",
                           "/link.txt", "/assets/", "/index.html%00.js", "//etc/passwd"}) {
    httplib::Client raw("127.0.0.1", web->port());
    auto r = raw.Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 404) << path << ": " << r->body.substr(0, 80);
    EXPECT_EQ(r->body.find("outside the web folder"), std::string::npos) << path;
    EXPECT_EQ(r->body.find("hidden"), std::string::npos) << path;
  }
}

TEST_F(WebFixture, SessionFilesAreServedFromTheirSessionOnly) {
  const std::string cookie = log_in();
  const fs::path session = lab.config.sessions_dir / "20261205T000000Z-standard-abc123";
  fs::create_directories(session / "results");
  std::ofstream(session / "results" / "summary.json") << R"({"state":"available"})";
  std::ofstream(session / "albedo-w57+blue:8-cam0.exr") << "EXR";
  std::ofstream(lab.config.sessions_dir / "audit.jsonl", std::ios::app);
  auto c = client();
  auto summary = c.Get("/api/files/20261205T000000Z-standard-abc123/results/summary.json", {{"Cookie", cookie}});
  ASSERT_TRUE(summary);
  EXPECT_EQ(summary->status, 200);
  EXPECT_EQ(summary->body, R"({"state":"available"})");
  auto derived = c.Get("/api/files/20261205T000000Z-standard-abc123/albedo-w57+blue:8-cam0.exr", {{"Cookie", cookie}});
  ASSERT_TRUE(derived);
  EXPECT_EQ(derived->status, 200);
  auto logged_out = c.Get("/api/files/20261205T000000Z-standard-abc123/results/summary.json");
  ASSERT_TRUE(logged_out);
  EXPECT_EQ(logged_out->status, 401);
  for (const char* path : {"/api/files/20261205T000000Z-standard-abc123/../audit.jsonl",
                           "/api/files/20261205T000000Z-standard-abc123/%2e%2e/audit.jsonl",
                           "/api/files/../audit.jsonl", "/api/files/.hidden/x", "/api/files/nosuchsession/results/summary.json",
                           "/api/files/20261205T000000Z-standard-abc123/results/"}) {
    auto r = c.Get(path, {{"Cookie", cookie}});
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 404) << path;
  }
}

TEST_F(WebFixture, TheBridgeAnswersAsTheApiDoesAndBadJsonChangesNothing) {
  const std::string cookie = log_in();
  // The same call straight over gRPC (the in-process channel with the token).
  auto channel = server->in_process_channel();
  auto stub = pb::LedService::NewStub(channel);
  grpc::ClientContext context;
  context.AddMetadata("authorization", std::string("Bearer ") + kWebToken);
  pb::LedStatus direct;
  ASSERT_TRUE(stub->GetLedState(&context, pb::GetLedStateRequest{}, &direct).ok());
  std::string direct_json;
  google::protobuf::util::JsonPrintOptions as_the_bridge_prints;  // docs/web.md: proto field names, defaults printed
  as_the_bridge_prints.always_print_primitive_fields = true;
  as_the_bridge_prints.preserve_proto_field_names = true;
  ASSERT_TRUE(google::protobuf::util::MessageToJsonString(direct, &direct_json, as_the_bridge_prints).ok());
  auto bridged = api(cookie, "LedService/GetLedState", "{}");
  ASSERT_TRUE(bridged);
  ASSERT_EQ(bridged->status, 200);
  EXPECT_EQ(nlohmann::json::parse(bridged->body), nlohmann::json::parse(direct_json));

  const drivers::DriveLevels before = lab.emitted();
  for (const char* body : {"{bad", R"({"state":{"drive":"lots"}})", R"({"no_such_field":1})", "[]"}) {
    auto r = api(cookie, "LedService/SetLedState", body);
    ASSERT_TRUE(r) << body;
    EXPECT_EQ(r->status, 400) << body << ": " << r->body;
    const auto error = nlohmann::json::parse(r->body);
    EXPECT_EQ(error.value("code", ""), "INVALID_ARGUMENT") << body;
    EXPECT_FALSE(error.value("error", "").empty()) << body;
  }
  EXPECT_EQ(lab.emitted(), before);
  auto unknown = api(cookie, "NoSuchService/NoSuchMethod", "{}");
  ASSERT_TRUE(unknown);
  EXPECT_EQ(unknown->status, 404);
}

TEST_F(WebFixture, ThePreviewStreamDeliversDownscaledFramesWithHistogramAndClippedMask) {
  const std::string cookie = log_in();
  // Bright enough that the white target clips: the mask has set bits.
  auto lit = api(cookie, "LedService/SetLedState", R"({"state":{"drive":{"w57":1.0}},"output_enabled":true})");
  ASSERT_TRUE(lit);
  ASSERT_EQ(lit->status, 200) << lit->body;
  auto exposed = api(cookie, "CameraService/SetCameraSettings", R"({"camera":"cam0","exposure_us":200000})");
  ASSERT_TRUE(exposed);
  ASSERT_EQ(exposed->status, 200) << exposed->body;
  httplib::Client c("127.0.0.1", web->port());
  c.set_read_timeout(30, 0);
  std::string buffer;
  std::vector<nlohmann::json> frames;
  auto r = c.Get("/api/stream/preview?rate_hz=10&width=80", {{"Cookie", cookie}}, [&](const char* data, std::size_t size) {
    buffer.append(data, size);
    for (std::size_t end; (end = buffer.find("\n\n")) != std::string::npos;) {
      const std::string event = buffer.substr(0, end);
      buffer.erase(0, end + 2);
      if (event.rfind("data: ", 0) == 0) frames.push_back(nlohmann::json::parse(event.substr(6)));
    }
    return frames.size() < 3;
  });
  ASSERT_GE(frames.size(), 3u) << (r ? r->body : "no response");
  for (const auto& f : frames) {
    EXPECT_EQ(f["camera"], "cam0");
    EXPECT_EQ(f["width"], 80);
    EXPECT_EQ(f["height"], 60);  // 160×120 frames, aspect kept
    EXPECT_EQ(f["source_width"], 160);
    EXPECT_EQ(f["source"], "free_run");
    EXPECT_FALSE(f["jpeg"].get<std::string>().empty());
    ASSERT_EQ(f["histogram"].size(), 64u);
    std::uint64_t counted = 0;
    for (const auto& bin : f["histogram"]) counted += bin.get<std::uint64_t>();
    EXPECT_GT(counted, 0u);
    // The clipped mask: one bit per preview pixel, its set bits counted in clipped_pixels.
    const std::string mask = base64_decode(f.value("clipped_mask", std::string()));
    EXPECT_EQ(mask.size(), (80u * 60u + 7) / 8);
    std::size_t set = 0;
    for (unsigned char byte : mask) set += std::bitset<8>(byte).count();
    EXPECT_EQ(set, f.value("clipped_pixels", 0u));
    EXPECT_GT(set, 0u);
  }
  // Sequences grow: each update is a newer frame.
  EXPECT_LT(std::stoull(frames[0]["sequence"].get<std::string>()), std::stoull(frames[2]["sequence"].get<std::string>()));
}

// Settings changed while the live view streams: each change restarts the
// free run. A watcher starting the run again while a stop was still joining
// the camera's stream deadlocked the hub once in the browser test (the
// stream's last callback waited for the hub, the watcher for the camera, the
// stop for the stream; fixed from that lock order). The race needs a frame
// inside the stop's window: this test exercises the path and did not hang
// the code before the fix in two runs, so it guards, it does not prove.
TEST_F(WebFixture, SettingsChangedWhileThePreviewStreamsAreAnsweredAndTheStreamGoesOn) {
  const std::string cookie = log_in();
  std::atomic<bool> done{false};
  std::atomic<int> frames{0};
  std::thread watcher([&] {
    httplib::Client c("127.0.0.1", web->port());
    c.set_read_timeout(60, 0);
    c.Get("/api/stream/preview?rate_hz=20&width=64", {{"Cookie", cookie}}, [&](const char* data, std::size_t size) {
      for (std::size_t i = 0; i + 5 < size; ++i) frames += std::string_view(data + i, 5) == "data:";
      return !done;
    });
  });
  for (int i = 0; i < 20 && frames == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  for (int i = 0; i < 12; ++i) {
    auto c = client();
    c.set_read_timeout(10, 0);
    auto r = c.Post("/api/CameraService/SetCameraSettings", {{"Origin", origin}, {"Cookie", cookie}},
                    nlohmann::json{{"camera", "cam0"}, {"exposure_us", 1000 + 500 * i}}.dump(), "application/json");
    ASSERT_TRUE(r) << "change " << i << " got no answer in 10 s";
    EXPECT_EQ(r->status, 200) << r->body;
  }
  const int before = frames;
  for (int i = 0; i < 50 && frames <= before; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_GT(frames.load(), before) << "the stream stopped after the changes";
  done = true;
  watcher.join();
}

TEST_F(WebFixture, CameraSettingsAreRefusedDuringASessionSayingWhy) {
  const std::string cookie = log_in();
  auto changed = api(cookie, "CameraService/SetCameraSettings", R"({"camera":"cam0","exposure_us":4000})");
  ASSERT_TRUE(changed);
  ASSERT_EQ(changed->status, 200) << changed->body;
  EXPECT_EQ(nlohmann::json::parse(changed->body)["exposure_us"], 4000);

  auto started = daemon->start_session(testing::quick_standard_plan(1), "web test");
  auto refused = api(cookie, "CameraService/SetCameraSettings", R"({"camera":"cam0","exposure_us":8000})");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 409) << refused->body;
  EXPECT_NE(nlohmann::json::parse(refused->body).value("error", "").find("session"), std::string::npos) << refused->body;
  auto led = api(cookie, "LedService/SetLedState", R"({"state":{"drive":{"w57":0.1}}})");
  ASSERT_TRUE(led);
  EXPECT_EQ(led->status, 409) << led->body;

  const auto final = testing::wait_for(*daemon, started.id, [](const session::OperationRecord& r) {
    return session::is_final(r.state);
  }, std::chrono::seconds(120));
  EXPECT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  auto listed = api(cookie, "CameraService/ListCameras", "{}");
  ASSERT_TRUE(listed);
  EXPECT_EQ(nlohmann::json::parse(listed->body)["cameras"][0]["exposure_us"], 4000);  // the refused change changed nothing
}

TEST(WebConfig, TheWebViewNeedsALongTokenAndTlsOffLoopback) {
  DaemonConfig config;
  config.sessions_dir = fs::temp_directory_path();
  config.web_address = "127.0.0.1:8080";
  config.token = "short";
  std::string error;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("token"), std::string::npos) << error;
  config.token = "a-token-of-sixteen-or-more";
  EXPECT_TRUE(config.IsValid(&error)) << error;
  config.web_address = "192.0.2.10:8080";
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("TLS"), std::string::npos) << error;
}

}  // namespace
}  // namespace chromo::daemon
