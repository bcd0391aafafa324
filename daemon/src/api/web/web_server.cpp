// The operator's web view: HTTP(S), log-in, static files, the API bridge
// (web_server.hpp; docs/web.md).
#include "chromo/daemon/web_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/random.h>

#include <cstring>

#include <chrono>
#include <deque>
#include <map>
#include <optional>
#include <mutex>
#include <thread>

#include <httplib.h>
#include <nlohmann/json.hpp>

#include "guarded_http.hpp"
#include "static_files.hpp"
#include "chromo/daemon/internal/api/metrics.hpp"
#include "web_bridge.hpp"

namespace chromo::daemon {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr auto kSessionLifetime = std::chrono::hours(12);
constexpr auto kLoginWindow = std::chrono::minutes(1);
constexpr const char* kCookieName = "chromo_session";
constexpr int kHttpThreads = 48;  // SSE streams hold one each (web_max_streams, below this, limits them)

const char* kContentSecurityPolicy =
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; "
    "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'";

std::string random_hex(std::size_t bytes) {
  std::string raw(bytes, '\0');
  std::size_t got = 0;
  while (got < bytes) {
    const ssize_t n = ::getrandom(raw.data() + got, bytes - got, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error("getrandom failed");
    got += static_cast<std::size_t>(n);
  }
  static const char* digits = "0123456789abcdef";
  std::string hex;
  for (unsigned char c : raw) hex += digits[c >> 4], hex += digits[c & 15];
  return hex;
}

bool equal_constant_time(const std::string& a, const std::string& b) {
  unsigned char difference = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) difference |= static_cast<unsigned char>(a[i] ^ b[i]);
  return difference == 0;
}

// The response closes its connection: nothing after it is read (a refused
// body's unread rest is not parsed as further requests).
void closing(httplib::Response& response) {
  response.set_header("Connection", "close");
  web::close_connection_after_response();
}

// Whose log-in attempts count together: every loopback address is one source
// (any local process may bind 127.x.y.z: issue 40 cycled 49 of them for 5
// fresh tries each), an IPv4-mapped address is its IPv4 one, an IPv6 address
// counts by its /64 (what one host is usually given).
std::string login_source(const std::string& address) {
  std::string a = address;
  if (a.rfind("::ffff:", 0) == 0 && a.find('.') != std::string::npos) a = a.substr(7);
  if (a.rfind("127.", 0) == 0 || a == "::1") return "loopback";
  in6_addr v6{};
  if (a.find(':') != std::string::npos && ::inet_pton(AF_INET6, a.c_str(), &v6) == 1) {
    char text[INET6_ADDRSTRLEN] = {};
    std::memset(v6.s6_addr + 8, 0, 8);
    ::inet_ntop(AF_INET6, &v6, text, sizeof text);
    return std::string(text) + "/64";
  }
  return a;
}

// The host part of a Host header ("127.0.0.1:8080" → "127.0.0.1",
// "[::1]:8080" → "[::1]") and its port (0 when none), or nullopt when malformed.
std::optional<std::pair<std::string, int>> split_host(const std::string& host) {
  std::string name = host, port;
  if (!host.empty() && host.front() == '[') {
    const auto close = host.find(']');
    if (close == std::string::npos) return std::nullopt;
    name = host.substr(0, close + 1);
    if (close + 1 < host.size()) {
      if (host[close + 1] != ':') return std::nullopt;
      port = host.substr(close + 2);
    }
  } else if (const auto colon = host.rfind(':'); colon != std::string::npos) {
    name = host.substr(0, colon), port = host.substr(colon + 1);
  }
  if (!is_valid_host_name(name)) return std::nullopt;
  if (port.empty()) return std::make_pair(name, 0);
  if (port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
  return std::make_pair(name, std::stoi(port));
}

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

}  // namespace

struct WebServer::State {
  DaemonConfig config;
  WebAuditor audit;
  web::ApiBridge bridge;
  std::shared_ptr<grpc::Channel> api_channel;  // /metrics' typed calls
  std::unique_ptr<httplib::Server> http;
  std::shared_ptr<web::ConnectionGuard> guard;
  std::thread thread;
  int port = 0;
  bool tls = false;

  std::mutex mutex;
  std::map<std::string, Clock::time_point> sessions;  // session id → expiry
  // Per log-in source (login_source): the failed attempts of the last
  // minute, and the refusals while rate limited, audited as one line each
  // lock-out (issue 40: each refusal appended an fsynced audit line).
  struct LoginSource {
    std::deque<Clock::time_point> failures;
    bool refusal_audited = false;
    std::uint64_t refusals_not_audited = 0;
  };
  std::map<std::string, LoginSource> failed_logins;
  std::uint32_t open_streams = 0;  // event and preview streams (web_max_streams)

  State(const DaemonConfig& c, std::shared_ptr<grpc::Channel> channel, WebAuditor a)
      : config(c), audit(std::move(a)), bridge(channel, c.token), api_channel(std::move(channel)) {}

  bool logged_in(const httplib::Request& request) {
    const std::string cookies = request.get_header_value("Cookie");
    const std::string key = std::string(kCookieName) + "=";
    for (std::size_t at = cookies.find(key); at != std::string::npos; at = cookies.find(key, at + 1)) {
      if (at != 0 && cookies[at - 1] != ' ' && cookies[at - 1] != ';') continue;
      const std::string id = cookies.substr(at + key.size(), 64);
      std::lock_guard lock(mutex);
      auto found = sessions.find(id);
      if (found != sessions.end() && found->second > Clock::now()) return true;
    }
    return false;
  }

  // /metrics also takes the token itself (a Prometheus scraper does not log
  // in): "Authorization: Bearer <token>".
  bool bearer_token(const httplib::Request& request) const {
    const std::string header = request.get_header_value("Authorization");
    const std::string prefix = "Bearer ";
    return header.rfind(prefix, 0) == 0 && equal_constant_time(header.substr(prefix.size()), config.token);
  }

  std::string cookie(const std::string& id, bool expire) const {
    std::string text = std::string(kCookieName) + "=" + id + "; Path=/; HttpOnly; SameSite=Strict";
    text += expire ? "; Max-Age=0" : "; Max-Age=" + std::to_string(std::chrono::duration_cast<std::chrono::seconds>(kSessionLifetime).count());
    if (tls) text += "; Secure";
    return text;
  }

  // Whether the Host header names this server (issue 40, row 10: DNS
  // rebinding): a loopback name, the web_address host, the numeric address
  // the request arrived on, or one of web_host_names; with this server's port
  // (or none, on the scheme's default port).
  bool known_host(const httplib::Request& request) const {
    const auto host = split_host(request.get_header_value("Host"));
    if (!host) return false;
    const auto& [name, given_port] = *host;
    if (given_port != 0 ? given_port != port : port != (tls ? 443 : 80)) return false;
    const std::string n = lower(name);
    if (n == "localhost" || n == "[::1]" || n.rfind("127.", 0) == 0) return true;
    const std::string local = request.local_addr.find(':') != std::string::npos ? "[" + request.local_addr + "]" : request.local_addr;
    if (n == lower(local)) return true;
    if (const auto configured = split_host(config.web_address); configured && n == lower(configured->first)) return true;
    for (const auto& allowed : config.web_host_names)
      if (n == lower(allowed)) return true;
    return false;
  }

  // The page's own origin as the browser names it: scheme://Host.
  bool same_origin(const httplib::Request& request) const {
    const std::string origin = request.get_header_value("Origin");
    const std::string host = request.get_header_value("Host");
    if (origin.empty() || host.empty()) return false;
    return origin == std::string(tls ? "https://" : "http://") + host;
  }

  // The request's body through httplib's content reader, so that a chunked
  // or compressed body is counted as it arrives (httplib caps only a body
  // with Content-Length itself, and reads a chunked one to its end): at most
  // web_max_body_bytes, else 413 and nullopt; a malformed one: 400.
  std::optional<std::string> read_body(const httplib::ContentReader& reader, httplib::Response& response) const {
    const std::size_t limit = config.web_max_body_bytes;
    std::string body;
    bool too_long = false;
    const bool complete = reader([&](const char* data, std::size_t size) {
      if (size > limit - body.size()) {
        too_long = true;
        return false;
      }
      body.append(data, size);
      return true;
    });
    if (too_long || response.status == 413) {
      response.status = 413;
      closing(response);
      response.set_content(web::error_json("request body: longer than web_max_body_bytes (" + std::to_string(limit) +
                                               " bytes)", "RESOURCE_EXHAUSTED"),
                           "application/json");
      return std::nullopt;
    }
    if (!complete) {
      response.status = 400;
      closing(response);
      response.set_content(web::error_json("request body: unreadable (broken chunked encoding or compression)",
                                           "INVALID_ARGUMENT"),
                           "application/json");
      return std::nullopt;
    }
    response.status = -1;
    return body;
  }

  void login(const httplib::Request& request, const std::string& body_text, httplib::Response& response) {
    const std::string who = "web:" + request.remote_addr;
    const std::string source = login_source(request.remote_addr);
    {
      std::string audit_line;
      std::unique_lock lock(mutex);
      if (failed_logins.size() > 4096)  // sources with nothing left to remember
        for (auto it = failed_logins.begin(); it != failed_logins.end();)
          it = it->second.failures.empty() && it->second.refusals_not_audited == 0 ? failed_logins.erase(it) : std::next(it);
      auto& entry = failed_logins[source];
      auto& failures = entry.failures;
      while (!failures.empty() && Clock::now() - failures.front() > kLoginWindow) failures.pop_front();
      if (failures.size() >= static_cast<std::size_t>(kMaxFailedLogins)) {
        const auto wait_s = std::chrono::duration_cast<std::chrono::seconds>(kLoginWindow - (Clock::now() - failures.front())).count() + 1;
        if (!entry.refusal_audited)
          audit_line = "rate limited: " + std::to_string(kMaxFailedLogins) + " failed log-ins in a minute from " + source +
                       " (further refusals are counted in one line when the limit ends)";
        else
          ++entry.refusals_not_audited;
        entry.refusal_audited = true;
        lock.unlock();
        if (!audit_line.empty()) audit(who, "web_login", audit_line);
        response.status = 429;
        response.set_header("Retry-After", std::to_string(wait_s));
        response.set_content(web::error_json("too many failed log-ins from " + source + "; try again in " +
                                                 std::to_string(wait_s) + " s", "RESOURCE_EXHAUSTED"),
                             "application/json");
        return;
      }
      if (entry.refusals_not_audited > 0)
        audit_line = "rate limited: " + std::to_string(entry.refusals_not_audited) + " further log-in attempts from " + source +
                     " refused (not audited one by one)";
      entry.refusal_audited = false;
      entry.refusals_not_audited = 0;
      lock.unlock();
      if (!audit_line.empty()) audit(who, "web_login", audit_line);
    }
    std::string token;
    try {
      const auto body = nlohmann::json::parse(body_text);
      token = body.at("token").get<std::string>();
    } catch (const std::exception&) {
      response.status = 400;
      response.set_content(web::error_json("body: expected {\"token\": \"...\"}", "INVALID_ARGUMENT"), "application/json");
      return;
    }
    if (!equal_constant_time(token, config.token)) {
      {
        std::lock_guard lock(mutex);
        failed_logins[source].failures.push_back(Clock::now());
      }
      audit(who, "web_login", "wrong token");
      response.status = 401;
      response.set_content(web::error_json("wrong token", "UNAUTHENTICATED"), "application/json");
      return;
    }
    const std::string id = random_hex(32);
    {
      std::lock_guard lock(mutex);
      for (auto it = sessions.begin(); it != sessions.end();) it = it->second <= Clock::now() ? sessions.erase(it) : std::next(it);
      sessions[id] = Clock::now() + kSessionLifetime;
      failed_logins.erase(source);
    }
    audit(who, "web_login", "");
    response.set_header("Set-Cookie", cookie(id, false));
    response.set_content("{\"logged_in\":true}", "application/json");
  }

  void logout(const httplib::Request& request, httplib::Response& response) {
    const std::string cookies = request.get_header_value("Cookie");
    const std::string key = std::string(kCookieName) + "=";
    if (auto at = cookies.find(key); at != std::string::npos) {
      std::lock_guard lock(mutex);
      sessions.erase(cookies.substr(at + key.size(), 64));
    }
    response.set_header("Set-Cookie", cookie("", true));
    response.set_content("{\"logged_in\":false}", "application/json");
  }

  // GET /api/stream/<name>: server-sent events over a streaming method.
  // At most web_max_streams at once (429 beyond): a slot is held by the
  // response's content provider and given back when httplib destroys it.
  // While idle, a stream writes an SSE comment every web_stream_keepalive_ms
  // and ends when the browser is gone (issue 40: an idle events stream kept
  // its thread and its API stream slot after the page closed).
  void event_stream(const httplib::Request& request, httplib::Response& response, const std::string& service,
                    const std::string& method, const std::string& request_json) {
    std::shared_ptr<void> slot;
    {
      std::lock_guard lock(mutex);
      if (open_streams >= config.web_max_streams) {
        response.status = 429;
        response.set_content(web::error_json("too many streams open (web_max_streams = " +
                                                 std::to_string(config.web_max_streams) + ")", "RESOURCE_EXHAUSTED"),
                             "application/json");
        return;
      }
      ++open_streams;
      slot = std::shared_ptr<void>(nullptr, [this](void*) {
        std::lock_guard lock(mutex);
        --open_streams;
      });
    }
    response.set_header("Cache-Control", "no-store");
    response.set_chunked_content_provider("text/event-stream", [this, service, method, request_json, slot](std::size_t, httplib::DataSink& sink) {
      const auto send = [&sink](const std::string& json) {
        const std::string event = "data: " + json + "\n\n";
        return sink.is_writable() && sink.write(event.data(), event.size());
      };
      const auto still_there = [&sink] {
        static constexpr char kComment[] = ":\n\n";
        return sink.is_writable() && sink.write(kComment, sizeof kComment - 1);
      };
      const web::BridgeReply end = bridge.stream(service, method, request_json, send,
                                                 std::chrono::milliseconds(config.web_stream_keepalive_ms), still_there);
      if (!end.json.empty()) {
        const std::string event = "event: failure\ndata: " + end.json + "\n\n";
        if (sink.is_writable()) sink.write(event.data(), event.size());
      }
      sink.done();
      return false;
    });
    (void)request;
  }

  // The whole web surface, in the order httplib matches it (per method, first
  // registered first): headers, the checks before any route, then the routes.
  void routes() {
    set_default_headers();
    http->set_pre_routing_handler(
        [this](const httplib::Request& request, httplib::Response& response) { return screen(request, response); });
    log_in_routes();
    metrics_route();
    stream_routes();
    api_routes();
    file_routes();
  }

  // The body cap and the security headers every response carries.
  void set_default_headers() {
    http->set_payload_max_length(config.web_max_body_bytes);
    httplib::Headers headers{{"Content-Security-Policy", kContentSecurityPolicy},
                             {"Referrer-Policy", "same-origin"},
                             {"X-Content-Type-Options", "nosniff"},
                             {"X-Frame-Options", "DENY"},
                             {"Cross-Origin-Opener-Policy", "same-origin"}};
    // Under TLS the browser is told to come back over TLS only (a year).
    if (tls) headers.emplace("Strict-Transport-Security", "max-age=31536000");
    http->set_default_headers(std::move(headers));
  }

  // The checks before any route (method, body type, Host, origin, log-in):
  // Handled with the refusal in `response`, or Unhandled to route on.
  httplib::Server::HandlerResponse screen(const httplib::Request& request, httplib::Response& response) {
    // A body nothing will read (a GET's, or one refused below) must not
    // stay in the connection to be parsed as the next request.
    const bool body = request.has_header("Transfer-Encoding") ||
                      (request.has_header("Content-Length") && request.get_header_value("Content-Length") != "0");
    if (body && (request.method == "GET" || request.method == "HEAD")) closing(response);
    // Only what the view uses, refused before any body is read (httplib reads
    // the body of a PUT, PATCH or DELETE whole before looking for a route).
    if (request.method != "GET" && request.method != "HEAD" && request.method != "POST") {
      response.status = 405;
      response.set_header("Allow", "GET, HEAD, POST");
      closing(response);
      response.set_content(web::error_json("method " + request.method.substr(0, 16) + " not allowed", "UNIMPLEMENTED"),
                           "application/json");
      return httplib::Server::HandlerResponse::Handled;
    }
    // Bodies are JSON: a multipart body would go to httplib's form parser.
    if (request.method == "POST" && request.get_header_value("Content-Type").rfind("multipart/", 0) == 0) {
      response.status = 415;
      closing(response);
      response.set_content(web::error_json("Content-Type: multipart bodies are not accepted (JSON only)", "INVALID_ARGUMENT"),
                           "application/json");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (!known_host(request)) {
      response.status = 421;
      closing(response);
      response.set_content(web::error_json("Host \"" + request.get_header_value("Host").substr(0, 128) +
                                               "\" is not this server's (a loopback name, its address, or one of "
                                               "web_host_names)", "PERMISSION_DENIED"),
                           "application/json");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (request.method != "GET" && request.method != "HEAD" && !same_origin(request)) {
      response.status = 403;
      if (body) closing(response);
      response.set_content(web::error_json("cross-origin request refused (Origin \"" + request.get_header_value("Origin") +
                                               "\" is not this page's)", "PERMISSION_DENIED"),
                           "application/json");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (request.path == "/metrics" && !logged_in(request) && !bearer_token(request)) {
      response.status = 401;
      response.set_header("WWW-Authenticate", "Bearer");
      if (body) closing(response);
      response.set_content(web::error_json("log in first, or send Authorization: Bearer <token>", "UNAUTHENTICATED"),
                           "application/json");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (request.path.rfind("/api/", 0) == 0 && !logged_in(request)) {
      response.status = 401;
      if (body) closing(response);
      response.set_content(web::error_json("log in first", "UNAUTHENTICATED"), "application/json");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  }

  // Log in and out, and whoami. Every POST reads its body through read_body
  // (the cap holds for chunked bodies too); a POST to no route is refused
  // after a bounded read (api_routes).
  void log_in_routes() {
    http->Post("/login", [this](const httplib::Request& q, httplib::Response& r, const httplib::ContentReader& reader) {
      if (const auto body = read_body(reader, r)) login(q, *body, r);
    });
    http->Post("/logout", [this](const httplib::Request& q, httplib::Response& r, const httplib::ContentReader& reader) {
      if (read_body(reader, r)) logout(q, r);
    });
    http->Get("/api/whoami", [](const httplib::Request&, httplib::Response& r) {
      r.set_header("Cache-Control", "no-store");
      r.set_content("{\"logged_in\":true}", "application/json");
    });
  }

  // chromod's counters for Prometheus (docs/observability.md), after the
  // same checks as the API (Host, log-in or the bearer token).
  void metrics_route() {
    http->Get("/metrics", [this](const httplib::Request&, httplib::Response& r) {
      r.set_header("Cache-Control", "no-store");
      try {
        r.set_content(web::collect_metrics(api_channel, config.token), "text/plain; version=0.0.4; charset=utf-8");
      } catch (const std::exception& error) {
        r.status = 503;
        r.set_content(web::error_json(error.what(), "UNAVAILABLE"), "application/json");
      }
    });
  }

  // The server-sent event streams: camera previews and the daemon's events.
  void stream_routes() {
    http->Get("/api/stream/preview", [this](const httplib::Request& q, httplib::Response& r) {
      nlohmann::json message = nlohmann::json::object();
      try {
        if (q.has_param("camera")) message["camera"] = q.get_param_value("camera");
        if (q.has_param("rate_hz")) message["rate_hz"] = std::stod(q.get_param_value("rate_hz"));
        if (q.has_param("width")) message["width"] = std::stoul(q.get_param_value("width"));
      } catch (const std::exception&) {
        r.status = 400;
        r.set_content(web::error_json("rate_hz and width: numbers", "INVALID_ARGUMENT"), "application/json");
        return;
      }
      if (q.has_param("white_balance")) message["white_balance"] = q.get_param_value("white_balance") == "1";
      if (q.has_param("region")) {  // "x,y,width,height" in fractions of the frame; the service checks the range
        const auto region = web::parse_numbers(q.get_param_value("region"), 4);
        if (!region) {
          r.status = 400;
          r.set_content(web::error_json("region: four numbers x,y,width,height (fractions of the frame)", "INVALID_ARGUMENT"),
                        "application/json");
          return;
        }
        message["region"] = {{"x", (*region)[0]}, {"y", (*region)[1]}, {"width", (*region)[2]}, {"height", (*region)[3]}};
      }
      event_stream(q, r, "CameraService", "StreamPreview", message.dump());
    });
    http->Get("/api/stream/events", [this](const httplib::Request& q, httplib::Response& r) {
      event_stream(q, r, "EventService", "Subscribe", "{}");
    });
  }

  // An API call (the JSON bridge to the gRPC services), and a POST to no route.
  void api_routes() {
    http->Post(R"(/api/([A-Za-z0-9]+)/([A-Za-z0-9]+))", [this](const httplib::Request& q, httplib::Response& r,
                                                                const httplib::ContentReader& reader) {
      const auto body = read_body(reader, r);
      if (!body) return;
      const web::BridgeReply reply = bridge.call(q.matches[1], q.matches[2], *body);
      r.status = reply.http_status;
      r.set_header("Cache-Control", "no-store");
      r.set_content(reply.json, "application/json");
    });
    http->Post(R"(/.*)", [this](const httplib::Request& q, httplib::Response& r, const httplib::ContentReader& reader) {
      if (!read_body(reader, r)) return;
      r.status = 404;
      r.set_content(web::error_json("no route POST " + q.path.substr(0, 256), "NOT_FOUND"), "application/json");
    });
  }

  // Files: a session's own, and the front end's.
  void file_routes() {
    // A session's own files (maps.exr, previews, summary.json, the journal):
    // only inside that session's folder, after log-in (the pre-routing check).
    http->Get(R"(/api/files/([A-Za-z0-9_-][A-Za-z0-9_.-]{0,127})/(.+))", [this](const httplib::Request& q, httplib::Response& r) {
      const std::string id = q.matches[1], relative = q.matches[2];
      const auto file = web::static_file(config.sessions_dir / id, "/" + relative);
      if (!file) {
        r.status = 404;
        r.set_content(web::error_json("no file \"" + relative.substr(0, 256) + "\" in session \"" + id + "\"", "NOT_FOUND"),
                      "application/json");
        return;
      }
      web::serve_file(*file, r);
      r.set_header("Cache-Control", "no-store");
    });
    http->Get(R"(/.*)", [this](const httplib::Request& q, httplib::Response& r) {
      const auto file = web::static_file(config.web_dir, q.path);
      if (!file) {
        r.status = 404;
        r.set_content("not found: " + q.path.substr(0, 256) + "\n", "text/plain; charset=utf-8");
        return;
      }
      web::serve_file(*file, r);
      r.set_header("Cache-Control", file->extension() == ".html" ? "no-store" : "no-cache");
    });
  }
};

WebServer::WebServer(const DaemonConfig& config, std::shared_ptr<grpc::Channel> api_channel, WebAuditor audit)
    : state_(std::make_unique<State>(config, std::move(api_channel), std::move(audit))) {
  if (config.web_address.empty()) throw std::invalid_argument("web_address: not set");
  if (config.web_dir.empty() || !fs::is_directory(config.web_dir))
    throw std::runtime_error("web_dir: \"" + config.web_dir.string() + "\" is not a folder (build the front end: docs/web.md)");
  web::ConnectionLimits limits;
  limits.threads = kHttpThreads;
  limits.head_timeout = std::chrono::milliseconds(config.web_request_head_timeout_ms);
  limits.max_body_wire_bytes = 2 * config.web_max_body_bytes + (64u << 10);  // chunk framing on top of the body
  state_->tls = !config.tls_certificate_file.empty();
  state_->http = web::make_guarded_server(limits, state_->tls ? config.tls_certificate_file.c_str() : nullptr,
                                          config.tls_private_key_file.c_str(), &state_->guard);
  if (!state_->http->is_valid()) throw std::runtime_error("web_address: cannot use the TLS certificate and key");
  state_->routes();
  const auto colon = config.web_address.rfind(':');
  std::string host = config.web_address.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
  const int port = std::stoi(config.web_address.substr(colon + 1));
  state_->port = port == 0 ? state_->http->bind_to_any_port(host) : (state_->http->bind_to_port(host, port) ? port : -1);
  if (state_->port <= 0) throw std::runtime_error("web_address: cannot listen on " + config.web_address);
  state_->thread = std::thread([this] { state_->http->listen_after_bind(); });
}

WebServer::~WebServer() { stop(); }

int WebServer::port() const { return state_->port; }

void WebServer::stop() {
  if (!state_->http) return;
  state_->http->stop();
  if (state_->thread.joinable()) state_->thread.join();
}

}  // namespace chromo::daemon
