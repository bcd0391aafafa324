// The web view's request path (daemon/src/api/web/, docs/web.md): the bytes
// of one HTTP/1.1 connection sent to a real chromod web server on loopback
// (guarded connections, pre-routing checks, log-in, static and session files,
// the JSON bridge into chromosphere.v1 request messages). The bridge's API
// channel leads to no daemon, so every call it forwards ends UNAVAILABLE:
// what is fuzzed is the parsing up to there, not the services.
//
// In an input, "@HOST@" becomes the server's host:port and "@COOKIE@" a
// logged-in session cookie, so mutations reach past the Origin, Host and
// log-in checks. Findings besides the sanitizers': a reply that does not
// start with "HTTP/1.1 ", any reply carrying the secret planted beside the
// served folders (a path out of them, or the session's symbolic link to it)
// unless the input holds it, and a server that no longer accepts a connection.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <string_view>

#include <grpcpp/grpcpp.h>

#include "chromo/daemon/config.hpp"
#include "chromo/daemon/web_server.hpp"
#include "fuzz_support.hpp"

namespace {

namespace fs = std::filesystem;

constexpr std::string_view kSecret = "CHROMO-FUZZ-SECRET-outside-the-served-folders";
constexpr int kReplyWaitMs = 3000;

// One connection: `request` written, the write side closed, the reply read
// until the server closes it (or kReplyWaitMs without a byte).
std::string exchange(int port, std::string_view request) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) std::abort();
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    std::fprintf(stderr, "fuzz_web_request: the web server no longer accepts connections\n");
    std::abort();
  }
  for (std::size_t sent = 0; sent < request.size();) {
    const ssize_t n = ::send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server closed early (a refused head): fine
    sent += static_cast<std::size_t>(n);
  }
  ::shutdown(fd, SHUT_WR);
  std::string reply;
  char buffer[16384];
  pollfd readable{fd, POLLIN, 0};
  while (::poll(&readable, 1, kReplyWaitMs) == 1) {
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) break;
    reply.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return reply;
}

std::string replace_all(std::string text, std::string_view what, const std::string& by) {
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + by.size()))
    text.replace(at, what.size(), by);
  return text;
}

struct Server {
  fs::path root = chromo::fuzz::scratch_directory() / "web";
  std::unique_ptr<chromo::daemon::WebServer> web;
  std::string host, cookie;

  Server() {
    fs::create_directories(root / "site");
    fs::create_directories(root / "sessions" / "20260101T000000Z-standard-aaaaaa" / "results");
    std::ofstream(root / "site" / "index.html") << "<!doctype html><title>fuzz</title>";
    std::ofstream(root / "sessions" / "20260101T000000Z-standard-aaaaaa" / "results" / "summary.json") << "{}";
    std::ofstream(root / "secret.txt") << kSecret;
    fs::create_symlink(root / "secret.txt", root / "sessions" / "20260101T000000Z-standard-aaaaaa" / "link.txt");
    chromo::daemon::DaemonConfig config;
    config.web_address = "127.0.0.1:0";
    config.web_dir = root / "site";
    config.sessions_dir = root / "sessions";
    config.token = "fuzz-token-0123456789abcdef";
    config.web_request_head_timeout_ms = 2000;
    auto channel = grpc::CreateChannel("unix:" + (root / "no-daemon.sock").string(), grpc::InsecureChannelCredentials());
    web = std::make_unique<chromo::daemon::WebServer>(config, channel, [](const std::string&, const std::string&,
                                                                           const std::string&) {});
    host = "127.0.0.1:" + std::to_string(web->port());
    if (!log_in(config.token)) std::abort();
    token = config.token;
  }

  // A fresh session cookie; false (the old one kept) when the log-in is
  // refused, e.g. rate-limited after the inputs' wrong tokens.
  bool log_in(const std::string& with_token) {
    const std::string body = "{\"token\":\"" + with_token + "\"}";
    const std::string reply = exchange(web->port(), "POST /login HTTP/1.1\r\nHost: " + host + "\r\nOrigin: http://" + host +
                                                        "\r\nContent-Type: application/json\r\nContent-Length: " +
                                                        std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body);
    const auto at = reply.find("chromo_session=");
    if (at == std::string::npos) {
      std::fprintf(stderr, "fuzz_web_request: log-in refused:\n%.300s\n", reply.c_str());
      return false;
    }
    cookie = reply.substr(at, reply.find(';', at) - at);
    return true;
  }
  std::string token;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Server server;
  std::string request(reinterpret_cast<const char*>(data), size);
  request = replace_all(replace_all(std::move(request), "@HOST@", server.host), "@COOKIE@", server.cookie);
  const std::string reply = exchange(server.web->port(), request);
  // An input that logged the harness's cookie out: log in again, so later
  // inputs still reach past the log-in check.
  if (request.find("logout") != std::string::npos) server.log_in(server.token);
  if (!reply.empty() && !reply.starts_with("HTTP/1.1 ")) {
    std::fprintf(stderr, "fuzz_web_request: a reply that is not HTTP/1.1:\n%.200s\n", reply.c_str());
    std::abort();
  }
  // (An input holding the secret itself gets it echoed in an error message: not a finding.)
  if (reply.find(kSecret) != std::string::npos && request.find(kSecret) == std::string::npos) {
    std::fprintf(stderr, "fuzz_web_request: a file outside the served folders was served:\n%.400s\n", reply.c_str());
    std::abort();
  }
  return 0;
}
