// The operator's web view over real HTTP on loopback (daemon/include/chromo/
// daemon/web_server.hpp, docs/web.md): chromod's WebServer on the virtual
// lab's Daemon and gRPC Server, driven by cpp-httplib's client. Log-in and
// its cookie, the origin check, the security headers, static and session
// files kept inside their folders, the API bridge answering as the API does,
// bad JSON refused with nothing changed, the preview stream, and camera
// settings refused during a session.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <sstream>
#include <bitset>
#include <fstream>
#include <regex>
#include <thread>

#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>

#include "chromo/daemon/internal/api/metrics.hpp"
#include "chromo/daemon/server.hpp"
#include "chromo/daemon/web_server.hpp"
#include "../support/test_certificate.hpp"
#include "chromosphere/v1/events.grpc.pb.h"
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

// A raw HTTP client on loopback for what cpp-httplib's client will not send:
// a hostile peer's requests written byte by byte as given.
class RawConnection {
 public:
  explicit RawConnection(int port, const char* from = "127.0.0.1") {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) return;
    sockaddr_in local{};
    local.sin_family = AF_INET;
    ::inet_pton(AF_INET, from, &local.sin_addr);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0) close();
    sockaddr_in server{};
    server.sin_family = AF_INET;
    server.sin_port = htons(static_cast<std::uint16_t>(port));
    ::inet_pton(AF_INET, "127.0.0.1", &server.sin_addr);
    if (fd_ >= 0 && ::connect(fd_, reinterpret_cast<sockaddr*>(&server), sizeof server) != 0) close();
  }
  RawConnection(const RawConnection&) = delete;
  ~RawConnection() { close(); }
  bool connected() const { return fd_ >= 0; }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  // Writes all of `data` unless the server answers first or the connection
  // fails; true when all was written.
  bool send(const std::string& data) {
    std::size_t at = 0;
    while (fd_ >= 0 && at < data.size()) {
      pollfd p{fd_, POLLIN | POLLOUT, 0};
      if (::poll(&p, 1, 30000) <= 0) return false;
      if (p.revents & (POLLIN | POLLERR | POLLHUP)) return false;  // answered (or gone) before the end
      const ssize_t n = ::send(fd_, data.data() + at, data.size() - at, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
      if (n <= 0) return false;
      at += static_cast<std::size_t>(n);
      sent_ += static_cast<std::size_t>(n);
    }
    return at == data.size();
  }
  // What the server sent until it closed or `timeout_ms` passed.
  std::string receive(int timeout_ms = 30000) {
    std::string text;
    char buffer[4096];
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (fd_ >= 0) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now()).count();
      pollfd p{fd_, POLLIN, 0};
      if (left <= 0 || ::poll(&p, 1, static_cast<int>(left)) <= 0) break;
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n <= 0) break;
      text.append(buffer, static_cast<std::size_t>(n));
    }
    return text;
  }
  // True when the server closes its side (EOF or reset) within timeout_ms;
  // what it sends before is read and dropped.
  bool closed_by_server(int timeout_ms) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    char buffer[4096];
    while (fd_ >= 0) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now()).count();
      pollfd p{fd_, POLLIN, 0};
      if (left <= 0 || ::poll(&p, 1, static_cast<int>(left)) <= 0) return false;
      if (::recv(fd_, buffer, sizeof buffer, 0) <= 0) return true;
    }
    return false;
  }
  std::size_t sent() const { return sent_; }

 private:
  int fd_ = -1;
  std::size_t sent_ = 0;
};

// The status code of a raw HTTP response ("HTTP/1.1 413 ..."), 0 when none.
int status_of(const std::string& response) {
  if (response.rfind("HTTP/1.1 ", 0) != 0 || response.size() < 12) return 0;
  return std::atoi(response.substr(9, 3).c_str());
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

// Issue 40, row 1: a chunked body was read to its end (100 MiB, no log-in
// needed); now it is counted as it arrives and refused past
// web_max_body_bytes like a Content-Length one.
TEST_F(WebFixture, AChunkedBodyPastTheCapIsRefusedWith413WithoutReadingItAll) {
  RawConnection raw(web->port());
  ASSERT_TRUE(raw.connected());
  const std::string head = "POST /login HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(web->port()) + "\r\nOrigin: " + origin +
                           "\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n";
  ASSERT_TRUE(raw.send(head));
  const std::string chunk = "10000\r\n" + std::string(0x10000, ' ') + "\r\n";  // 64 KiB of JSON white space
  bool all_sent = true;
  for (int i = 0; i < 1600 && all_sent; ++i) all_sent = raw.send(chunk);  // 100 MiB
  const std::string response = raw.receive();
  EXPECT_FALSE(all_sent) << "the server read 100 MiB of chunked body";
  EXPECT_EQ(status_of(response), 413) << response.substr(0, 200);
  EXPECT_NE(response.find("web_max_body_bytes"), std::string::npos) << response.substr(0, 400);
  // The server stopped reading near the cap (1 MiB), whatever the kernel's
  // socket buffers took on top.
  EXPECT_LT(raw.sent(), 32u << 20);

  // A chunked body within the cap is read as any other: the log-in works.
  RawConnection small(web->port());
  const std::string token = nlohmann::json{{"token", kWebToken}}.dump();
  std::ostringstream chunked;
  chunked << std::hex << token.size() << "\r\n" << token << "\r\n0\r\n\r\n";
  ASSERT_TRUE(small.send(head + chunked.str()));
  const std::string ok = small.receive(5000);
  EXPECT_EQ(status_of(ok), 200) << ok.substr(0, 400);
  EXPECT_NE(ok.find("chromo_session="), std::string::npos);
}

// What httplib would have read whole before routing: the body of a method the
// view does not use, and a multipart body. Both are refused before reading.
TEST_F(WebFixture, OtherMethodsAndMultipartBodiesAreRefusedBeforeTheBodyIsRead) {
  for (const auto& method : std::vector<std::string>{"PUT", "PATCH", "DELETE", "OPTIONS"}) {
    RawConnection raw(web->port());
    ASSERT_TRUE(raw.send(method + " /login HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(web->port()) + "\r\nOrigin: " + origin +
                         "\r\nTransfer-Encoding: chunked\r\n\r\n"));
    EXPECT_EQ(status_of(raw.receive(5000)), 405) << method;
  }
  RawConnection raw(web->port());
  ASSERT_TRUE(raw.send("POST /login HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(web->port()) + "\r\nOrigin: " + origin +
                       "\r\nContent-Type: multipart/form-data; boundary=x\r\nTransfer-Encoding: chunked\r\n\r\n"));
  EXPECT_EQ(status_of(raw.receive(5000)), 415);
}

// A fixture whose limits are small enough to reach in a test.
struct SmallLimitsWebFixture : WebFixture {
  void SetUp() override {
    lab.config.max_streams = 4;
    lab.config.web_max_streams = 4;
    lab.config.web_stream_keepalive_ms = 200;
    WebFixture::SetUp();
  }
  // A Subscribe straight over gRPC with a 1 s deadline: RESOURCE_EXHAUSTED
  // when every stream slot is held, DEADLINE_EXCEEDED when it was served and
  // nothing happened.
  grpc::StatusCode subscribe_once() {
    auto stub = pb::EventService::NewStub(server->in_process_channel());
    grpc::ClientContext context;
    context.AddMetadata("authorization", std::string("Bearer ") + kWebToken);
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(1));
    auto reader = stub->Subscribe(&context, pb::SubscribeRequest{});
    pb::Event event;
    while (reader->Read(&event)) {
    }
    return reader->Finish().error_code();
  }
};

// Issue 40, row 2: a browser that left an idle events stream kept its HTTP
// thread and its max_streams slot until the next event (none while idle).
// Now the stream writes a comment every web_stream_keepalive_ms and ends when
// the client is gone.
TEST_F(SmallLimitsWebFixture, AnIdleEventStreamEndsWhenItsClientLeavesAndFreesItsSlot) {
  const std::string cookie = log_in();
  for (int i = 0; i < 4; ++i) {
    RawConnection raw(web->port());
    ASSERT_TRUE(raw.send("GET /api/stream/events HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(web->port()) +
                         "\r\nCookie: " + cookie + "\r\n\r\n"));
    const std::string head = raw.receive(1000);  // the headers, then keep-alive comments
    ASSERT_EQ(status_of(head), 200) << head.substr(0, 300);
    EXPECT_NE(head.find("text/event-stream"), std::string::npos);
  }  // each client leaves
  // Every slot comes back: a gRPC Subscribe is served again (waited for at
  // most 30 tries; before the fix, never).
  grpc::StatusCode code = grpc::StatusCode::RESOURCE_EXHAUSTED;
  for (int i = 0; i < 30 && code == grpc::StatusCode::RESOURCE_EXHAUSTED; ++i) code = subscribe_once();
  EXPECT_EQ(code, grpc::StatusCode::DEADLINE_EXCEEDED);
  // And the web view serves four streams again.
  std::vector<std::unique_ptr<RawConnection>> held;
  for (int i = 0; i < 4; ++i) {
    held.push_back(std::make_unique<RawConnection>(web->port()));
    ASSERT_TRUE(held.back()->send("GET /api/stream/events HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(web->port()) +
                                  "\r\nCookie: " + cookie + "\r\n\r\n"));
    const std::string head = held.back()->receive(1000);
    EXPECT_EQ(status_of(head), 200) << i << ": " << head.substr(0, 300);
    EXPECT_NE(head.find(":\n\n"), std::string::npos) << "no keep-alive comment in 1 s at 200 ms";
  }
}

// web_max_streams caps the web view's streams below its HTTP threads, so a
// page still loads while streams are open.
TEST_F(SmallLimitsWebFixture, StreamsBeyondWebMaxStreamsAreRefusedAndPagesStillLoad) {
  const std::string cookie = log_in();
  std::vector<std::unique_ptr<RawConnection>> held;
  for (int i = 0; i < 4; ++i) {
    held.push_back(std::make_unique<RawConnection>(web->port()));
    ASSERT_TRUE(held.back()->send("GET /api/stream/events HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(web->port()) +
                                  "\r\nCookie: " + cookie + "\r\n\r\n"));
    ASSERT_EQ(status_of(held.back()->receive(1000)), 200) << i;
  }
  auto c = client();
  auto refused = c.Get("/api/stream/events", {{"Cookie", cookie}});
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 429);
  EXPECT_NE(refused->body.find("web_max_streams"), std::string::npos) << refused->body;
  auto page = c.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
}

// A log-in POST written raw from `from` (a loopback address of its own), with
// `host` as the Host header and the matching Origin; the response's status.
int raw_log_in(int port, const std::string& token, const char* from = "127.0.0.1", std::string host = "") {
  if (host.empty()) host = "127.0.0.1:" + std::to_string(port);
  RawConnection raw(port, from);
  const std::string body = nlohmann::json{{"token", token}}.dump();
  if (!raw.send("POST /login HTTP/1.1\r\nHost: " + host + "\r\nOrigin: http://" + host +
                "\r\nContent-Type: application/json\r\nConnection: close\r\nContent-Length: " + std::to_string(body.size()) +
                "\r\n\r\n" + body))
    return 0;
  return status_of(raw.receive(10000));
}

// Issue 40, row 5: every rate-limited attempt appended an fsynced audit line
// (2000 requests: 304 KB). Now a lock-out is one line, whatever it refuses.
TEST_F(WebFixture, RateLimitedLogInsAreAuditedOnceNotOneLineEach) {
  auto c = client();
  int refused = 0;
  for (int i = 0; i < 200; ++i) {
    auto r = c.Post("/login", {{"Origin", origin}}, R"({"token":"guess-guess-guess-guess"})", "application/json");
    ASSERT_TRUE(r);
    refused += r->status == 429;
  }
  EXPECT_GE(refused, 200 - kMaxFailedLogins - 1);
  int wrong = 0, limited = 0;
  for (const auto& line : audit_lines()) {
    if (line.value("action", "") != "web_login") continue;
    const std::string error = line.value("error", "");
    wrong += error == "wrong token";
    limited += error.rfind("rate limited", 0) == 0;
  }
  EXPECT_EQ(wrong, kMaxFailedLogins);
  // One line per lock-out (a minute): more only if this loop outlasted one.
  EXPECT_GE(limited, 1);
  EXPECT_LE(limited, 4) << "every refusal audited one by one";
}

// Issue 40, row 9: the limit counted per address, and any 127.x.y.z is
// local: each new address had 5 fresh tries. Loopback is one source now.
TEST_F(WebFixture, TheLogInLimitTreatsEveryLoopbackAddressAsOneSource) {
  std::vector<int> statuses;
  for (int n = 2; n < 2 + kMaxFailedLogins + 3; ++n) {
    const std::string from = "127.0.0." + std::to_string(n);
    statuses.push_back(raw_log_in(web->port(), "guess-guess-guess-guess", from.c_str()));
  }
  for (int i = 0; i < kMaxFailedLogins; ++i) EXPECT_EQ(statuses[static_cast<std::size_t>(i)], 401) << i;
  for (std::size_t i = kMaxFailedLogins; i < statuses.size(); ++i) EXPECT_EQ(statuses[i], 429) << i;
  EXPECT_EQ(raw_log_in(web->port(), kWebToken, "127.0.0.99"), 429);  // even the right token, from yet another address
}

// Issue 40, row 10: the Host header was not checked (DNS rebinding): five
// wrong log-ins with Host: attacker.example and a matching Origin locked
// the operator out. A Host that is not this server's is refused first.
TEST_F(WebFixture, AHostThatIsNotThisServersIsRefusedAndLocksNobodyOut) {
  const std::string attacker = "attacker.example:" + std::to_string(web->port());
  for (int i = 0; i < kMaxFailedLogins + 2; ++i) EXPECT_EQ(raw_log_in(web->port(), "guess-guess-guess-guess", "127.0.0.1", attacker), 421);
  EXPECT_EQ(raw_log_in(web->port(), kWebToken), 200);  // the operator is not locked out
  {
    RawConnection raw(web->port());
    ASSERT_TRUE(raw.send("GET / HTTP/1.1\r\nHost: " + attacker + "\r\nConnection: close\r\n\r\n"));
    const std::string response = raw.receive(10000);
    EXPECT_EQ(status_of(response), 421);
    EXPECT_NE(response.find("web_host_names"), std::string::npos);
    EXPECT_EQ(response.find("<title>chromo</title>"), std::string::npos);
  }
  // The names this server answers: loopback names and addresses, with its port.
  for (const std::string& host : {"127.0.0.1:" + std::to_string(web->port()), "localhost:" + std::to_string(web->port()),
                                 "LOCALHOST:" + std::to_string(web->port())}) {
    RawConnection raw(web->port());
    ASSERT_TRUE(raw.send("GET / HTTP/1.1\r\nHost: " + host + "\r\nConnection: close\r\n\r\n"));
    EXPECT_EQ(status_of(raw.receive(10000)), 200) << host;
  }
  for (const std::string& host : {std::string("127.0.0.1:1"), std::string(""), std::string("127.0.0.1:99999"),
                                 std::string("a b:1"), "localhost.attacker.example:" + std::to_string(web->port())}) {
    RawConnection raw(web->port());
    ASSERT_TRUE(raw.send("GET / HTTP/1.1\r\nHost: " + host + "\r\nConnection: close\r\n\r\n"));
    EXPECT_EQ(status_of(raw.receive(10000)), 421) << host;
  }
}

struct NamedHostWebFixture : WebFixture {
  void SetUp() override {
    lab.config.web_host_names = {"chromo.lab.example"};
    WebFixture::SetUp();
  }
};

TEST_F(NamedHostWebFixture, AConfiguredHostNameIsAnswered) {
  const std::string host = "chromo.lab.example:" + std::to_string(web->port());
  EXPECT_EQ(raw_log_in(web->port(), kWebToken, "127.0.0.1", host), 200);
  EXPECT_EQ(raw_log_in(web->port(), kWebToken, "127.0.0.1", "other.lab.example:" + std::to_string(web->port())), 421);
}

// Issue 40, row 6 (slowloris): 100 connections sending a header byte a
// second held every HTTP thread, and GET / timed out. A request head must
// now arrive within web_request_head_timeout_ms, and when every thread is
// busy the connection that has waited longest for its head is closed.
struct SlowClientsWebFixture : WebFixture {
  void SetUp() override {
    lab.config.web_request_head_timeout_ms = 2000;
    WebFixture::SetUp();
  }
};

TEST_F(SlowClientsWebFixture, SlowRequestHeadsHoldNoThreadForLongAndThePageIsServed) {
  const std::string host = "Host: 127.0.0.1:" + std::to_string(web->port()) + "\r\n";
  std::vector<std::unique_ptr<RawConnection>> slow;
  for (int i = 0; i < 60; ++i) {  // more than the 48 HTTP threads
    slow.push_back(std::make_unique<RawConnection>(web->port()));
    ASSERT_TRUE(slow.back()->send("GET / HTTP/1.1\r\n" + host));
  }
  std::atomic<bool> done{false};
  std::thread trickle([&] {  // a header byte every 300 ms on each, until the page is served
    while (!done) {
      for (auto& connection : slow) connection->send("X");
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  httplib::Client c("127.0.0.1", web->port());
  c.set_connection_timeout(10, 0);
  c.set_read_timeout(10, 0);
  auto page = c.Get("/");
  done = true;
  trickle.join();
  ASSERT_TRUE(page) << "GET / got no answer while 60 slow heads were held";
  EXPECT_EQ(page->status, 200);
  // Every slow connection is closed by the server, trickling or not.
  int closed = 0;
  for (auto& connection : slow) closed += connection->closed_by_server(10000);
  EXPECT_EQ(closed, 60);
}

// What cpp-httplib 0.11 alone keeps in memory: a request line (or header
// line) without an end, and a chunk-size line without an end. The
// connection is closed at the caps instead.
TEST_F(WebFixture, EndlessRequestAndChunkSizeLinesAreCutOffAtTheirCaps) {
  const std::string endless(64u << 20, 'a');  // 64 MiB, more than any socket buffer holds
  {
    RawConnection raw(web->port());
    EXPECT_FALSE(raw.send("GET /" + endless)) << "the server read 64 MiB of request line";
    EXPECT_LT(raw.sent(), 16u << 20);
    EXPECT_TRUE(raw.closed_by_server(10000));
  }
  {
    RawConnection raw(web->port());
    const std::string head = "POST /login HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(web->port()) + "\r\nOrigin: " + origin +
                             "\r\nTransfer-Encoding: chunked\r\n\r\n";
    EXPECT_FALSE(raw.send(head + std::string(64u << 20, 'f'))) << "the server read a 64 MiB chunk-size line";
    EXPECT_LT(raw.sent(), 16u << 20);
  }
  auto page = client().Get("/");  // and it serves on
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
}

// The web view over TLS is served by the same guarded connections: a real
// TLS client logs in and loads the page; a connection that never finishes
// its handshake is closed after web_request_head_timeout_ms.
struct TlsWebFixture : WebFixture {
  void SetUp() override {
    const auto certificate = chromo::testing::make_test_certificate(lab.directory);
    lab.config.tls_certificate_file = certificate.certificate_file.string();
    lab.config.tls_private_key_file = certificate.key_file.string();
    lab.config.web_request_head_timeout_ms = 1000;
    WebFixture::SetUp();
    origin = "https://127.0.0.1:" + std::to_string(web->port());
  }
};

TEST_F(TlsWebFixture, ATlsClientLogsInAndAStalledHandshakeIsClosed) {
  httplib::SSLClient c("127.0.0.1", web->port());
  c.enable_server_certificate_verification(false);
  c.set_read_timeout(20, 0);
  auto login = c.Post("/login", {{"Origin", origin}}, nlohmann::json{{"token", kWebToken}}.dump(), "application/json");
  ASSERT_TRUE(login) << httplib::to_string(login.error());
  EXPECT_EQ(login->status, 200) << login->body;
  EXPECT_NE(login->get_header_value("Set-Cookie").find("Secure"), std::string::npos);
  EXPECT_EQ(login->get_header_value("Strict-Transport-Security"), "max-age=31536000");  // issue 40, row 15
  auto page = c.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("<title>chromo</title>"), std::string::npos);
  auto too_long = c.Post("/login", {{"Origin", origin}}, std::string(2u << 20, ' '), "application/json");
  ASSERT_TRUE(too_long);
  EXPECT_EQ(too_long->status, 413);

  RawConnection stalled(web->port());  // TCP, then not a byte of the handshake
  ASSERT_TRUE(stalled.connected());
  EXPECT_TRUE(stalled.closed_by_server(10000));
}

// A body refused unread (a call before log-in: 401) must not stay in the
// connection: the browser's next request on it was read as "{}POST /login"
// (400) once connections kept their read buffer between requests.
TEST_F(WebFixture, ABodyRefusedUnreadClosesItsConnectionAndTheNextRequestIsServed) {
  RawConnection raw(web->port());
  const std::string host = "Host: 127.0.0.1:" + std::to_string(web->port()) + "\r\nOrigin: " + origin + "\r\n";
  // The refused call and, at once behind it on the same connection, a page.
  ASSERT_TRUE(raw.send("POST /api/LedService/GetLedState HTTP/1.1\r\n" + host +
                       "Content-Type: application/json\r\nContent-Length: 2\r\n\r\n{}"
                       "GET / HTTP/1.1\r\n" + host + "\r\n"));
  const std::string answers = raw.receive(10000);  // until the server closes
  EXPECT_EQ(status_of(answers), 401) << answers.substr(0, 200);
  EXPECT_EQ(answers.find("HTTP/1.1 400"), std::string::npos) << "the unread body was read as a request:\n" << answers;
  EXPECT_EQ(raw_log_in(web->port(), kWebToken), 200);
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
    EXPECT_FALSE(r->has_header("Strict-Transport-Security"));  // plain HTTP on loopback: only under TLS
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


// /metrics (docs/observability.md): behind the same checks as the API, with
// the log-in cookie or the token as a bearer; a finished session's counters.
struct MetricsWebFixture : WebFixture {
  void SetUp() override {
    lab.config.estimation.enabled = false;  // the frame counters, not the maps, are under test
    WebFixture::SetUp();
  }
};

TEST_F(MetricsWebFixture, MetricsNeedTheTokenAndCountASessionsFramesPerCameraAndSession) {
  auto none = client().Get("/metrics");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 401);
  auto wrong = client().Get("/metrics", {{"Authorization", "Bearer not-the-token-at-all"}});
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->status, 401);
  auto foreign = client().Get("/metrics", {{"Authorization", std::string("Bearer ") + kWebToken}, {"Host", "evil.example"}});
  ASSERT_TRUE(foreign);
  EXPECT_EQ(foreign->status, 421);
  auto with_cookie = client().Get("/metrics", {{"Cookie", log_in()}});
  ASSERT_TRUE(with_cookie);
  EXPECT_EQ(with_cookie->status, 200);

  const auto plan = testing::quick_standard_plan(1);
  const std::string frames = std::to_string(plan.frames_per_camera_total());  // 7: one of each step
  auto started = daemon->start_session(plan, "metrics");
  const auto final = testing::wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  auto scraped = client().Get("/metrics", {{"Authorization", std::string("Bearer ") + kWebToken}});
  ASSERT_TRUE(scraped);
  ASSERT_EQ(scraped->status, 200);
  EXPECT_EQ(scraped->get_header_value("Content-Type"), "text/plain; version=0.0.4; charset=utf-8");
  const std::string& text = scraped->body;
  const std::string session = "{session=\"" + started.id + "\",state=\"succeeded\"} ";
  EXPECT_NE(text.find("chromo_session_frames_expected" + session + frames + "\n"), std::string::npos) << text;
  EXPECT_NE(text.find("chromo_session_frames_stored_total" + session + frames + "\n"), std::string::npos) << text;
  EXPECT_NE(text.find("chromo_session_frames_lost_total" + session + "0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("chromo_sessions_running 0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("# TYPE chromo_camera_frames_completed_total counter\n"), std::string::npos);
  EXPECT_NE(text.find("chromo_camera_up{camera=\"cam0\"} 1\n"), std::string::npos) << text;
  std::smatch completed;
  ASSERT_TRUE(std::regex_search(text, completed, std::regex("chromo_camera_frames_completed_total\\{camera=\"cam0\"\\} ([0-9]+)\n")));
  EXPECT_GE(std::stoul(completed[1]), plan.frames_per_camera_total());  // the session's, and any live-view frames
}

// The formatter alone: the estimator's throughput is frames estimated per
// second of the session, label values escaped as Prometheus wants.
TEST(Metrics, ThroughputPerSessionAndEscapedLabels) {
  pb::ListCamerasResponse cameras;
  auto* camera = cameras.add_cameras();
  camera->set_name("cam\"0");
  camera->set_error("unreachable");
  camera->mutable_stream()->set_resent_packets(7);
  pb::ListOperationsResponse sessions;
  auto* done = sessions.add_operations();
  done->set_id("s1");
  done->set_state(pb::OPERATION_STATE_SUCCEEDED);
  done->mutable_created()->set_seconds(1000);
  done->mutable_updated()->set_seconds(1010);
  done->mutable_counters()->set_estimated(20);
  auto* running = sessions.add_operations();
  running->set_id("s2");
  running->set_state(pb::OPERATION_STATE_RUNNING);
  running->mutable_created()->set_seconds(2000);
  running->mutable_counters()->set_estimated(12);
  running->mutable_counters()->set_estimator_queue_depth(3);
  const std::string text = web::prometheus_text(cameras, sessions, std::chrono::system_clock::from_time_t(2004));
  EXPECT_NE(text.find("chromo_camera_up{camera=\"cam\\\"0\"} 0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("chromo_camera_resent_packets_total{camera=\"cam\\\"0\"} 7\n"), std::string::npos) << text;
  EXPECT_NE(text.find("chromo_session_estimator_frames_per_second{session=\"s1\",state=\"succeeded\"} 2\n"), std::string::npos) << text;
  EXPECT_NE(text.find("chromo_session_estimator_frames_per_second{session=\"s2\",state=\"running\"} 3\n"), std::string::npos) << text;
  EXPECT_NE(text.find("chromo_session_estimator_queue_depth{session=\"s2\",state=\"running\"} 3\n"), std::string::npos) << text;
  EXPECT_NE(text.find("chromo_sessions_running 1\n"), std::string::npos) << text;
}

}  // namespace
}  // namespace chromo::daemon
