// The operator's web view: HTTP(S), log-in, static files, the API bridge
// (web_server.hpp; docs/web.md).
#include "chromo/daemon/web_server.hpp"

#include <sys/random.h>

#include <chrono>
#include <deque>
#include <map>
#include <mutex>
#include <thread>

#include <httplib.h>
#include <nlohmann/json.hpp>

#include "web_bridge.hpp"

namespace chromo::daemon {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr auto kSessionLifetime = std::chrono::hours(12);
constexpr auto kLoginWindow = std::chrono::minutes(1);
constexpr const char* kCookieName = "chromo_session";
constexpr int kHttpThreads = 48;  // SSE streams hold one each (the API's max_streams limits them again)

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

std::string content_type_of(const fs::path& file) {
  static const std::map<std::string, std::string> types = {
      {".html", "text/html; charset=utf-8"}, {".js", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},   {".json", "application/json"},
      {".svg", "image/svg+xml"},             {".png", "image/png"},
      {".ico", "image/x-icon"},              {".map", "application/json"},
      {".jsonl", "application/x-ndjson"},    {".csv", "text/csv; charset=utf-8"},
      {".exr", "image/x-exr"}};
  auto found = types.find(file.extension().string());
  return found == types.end() ? "application/octet-stream" : found->second;
}

// A request path's file inside `root`, or nullopt: only [A-Za-z0-9_.+:-/]
// segments (a session's derived files are named "albedo-w57+blue:8-cam0.exr"),
// none empty or starting with '.', and the resolved file must be a regular
// file under the resolved root (a symbolic link out of it is refused).
std::optional<fs::path> static_file(const fs::path& root, std::string path) {
  if (path.empty() || path == "/") path = "/index.html";
  if (path.size() > 256 || path.front() != '/') return std::nullopt;
  std::size_t start = 1;
  while (start <= path.size()) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    const std::string segment = path.substr(start, end - start);
    if (segment.empty() || segment.front() == '.') return std::nullopt;
    for (char c : segment)
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == '+' || c == ':'))
        return std::nullopt;
    start = end + 1;
  }
  std::error_code error;
  const fs::path base = fs::canonical(root, error);
  if (error) return std::nullopt;
  const fs::path file = fs::weakly_canonical(base / path.substr(1), error);
  if (error || !fs::is_regular_file(file, error)) return std::nullopt;
  const auto relative = file.lexically_relative(base);
  if (relative.empty() || *relative.begin() == "..") return std::nullopt;
  return file;
}

void serve_file(const fs::path& file, httplib::Response& response) {
  std::ifstream in(file, std::ios::binary);
  std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  response.set_content(body, content_type_of(file));
}

}  // namespace

struct WebServer::State {
  DaemonConfig config;
  WebAuditor audit;
  web::ApiBridge bridge;
  std::unique_ptr<httplib::Server> http;
  std::thread thread;
  int port = 0;
  bool tls = false;

  std::mutex mutex;
  std::map<std::string, Clock::time_point> sessions;  // session id → expiry
  std::map<std::string, std::deque<Clock::time_point>> failed_logins;  // client address → times

  State(const DaemonConfig& c, std::shared_ptr<grpc::Channel> channel, WebAuditor a)
      : config(c), audit(std::move(a)), bridge(std::move(channel), c.token) {}

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

  std::string cookie(const std::string& id, bool expire) const {
    std::string text = std::string(kCookieName) + "=" + id + "; Path=/; HttpOnly; SameSite=Strict";
    text += expire ? "; Max-Age=0" : "; Max-Age=" + std::to_string(std::chrono::duration_cast<std::chrono::seconds>(kSessionLifetime).count());
    if (tls) text += "; Secure";
    return text;
  }

  // The page's own origin as the browser names it: scheme://Host.
  bool same_origin(const httplib::Request& request) const {
    const std::string origin = request.get_header_value("Origin");
    const std::string host = request.get_header_value("Host");
    if (origin.empty() || host.empty()) return false;
    return origin == std::string(tls ? "https://" : "http://") + host;
  }

  void login(const httplib::Request& request, httplib::Response& response) {
    const std::string who = "web:" + request.remote_addr;
    {
      std::lock_guard lock(mutex);
      auto& failures = failed_logins[request.remote_addr];
      while (!failures.empty() && Clock::now() - failures.front() > kLoginWindow) failures.pop_front();
      if (failures.size() >= static_cast<std::size_t>(kMaxFailedLogins)) {
        const auto wait_s = std::chrono::duration_cast<std::chrono::seconds>(kLoginWindow - (Clock::now() - failures.front())).count() + 1;
        audit(who, "web_login", "rate limited: " + std::to_string(kMaxFailedLogins) + " failed log-ins in a minute");
        response.status = 429;
        response.set_header("Retry-After", std::to_string(wait_s));
        response.set_content(web::error_json("too many failed log-ins from " + request.remote_addr + "; try again in " +
                                                 std::to_string(wait_s) + " s", "RESOURCE_EXHAUSTED"),
                             "application/json");
        return;
      }
    }
    std::string token;
    try {
      const auto body = nlohmann::json::parse(request.body);
      token = body.at("token").get<std::string>();
    } catch (const std::exception&) {
      response.status = 400;
      response.set_content(web::error_json("body: expected {\"token\": \"...\"}", "INVALID_ARGUMENT"), "application/json");
      return;
    }
    if (!equal_constant_time(token, config.token)) {
      {
        std::lock_guard lock(mutex);
        failed_logins[request.remote_addr].push_back(Clock::now());
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
      failed_logins.erase(request.remote_addr);
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
  void event_stream(const httplib::Request& request, httplib::Response& response, const std::string& service,
                    const std::string& method, const std::string& request_json) {
    response.set_header("Cache-Control", "no-store");
    response.set_chunked_content_provider("text/event-stream", [this, service, method, request_json](std::size_t, httplib::DataSink& sink) {
      const auto send = [&sink](const std::string& json) {
        const std::string event = "data: " + json + "\n\n";
        return sink.is_writable() && sink.write(event.data(), event.size());
      };
      const web::BridgeReply end = bridge.stream(service, method, request_json, send);
      if (!end.json.empty()) {
        const std::string event = "event: failure\ndata: " + end.json + "\n\n";
        if (sink.is_writable()) sink.write(event.data(), event.size());
      }
      sink.done();
      return false;
    });
    (void)request;
  }

  void routes() {
    http->set_payload_max_length(1 << 20);
    http->new_task_queue = [] { return new httplib::ThreadPool(kHttpThreads); };
    http->set_default_headers({{"Content-Security-Policy", kContentSecurityPolicy},
                               {"Referrer-Policy", "same-origin"},
                               {"X-Content-Type-Options", "nosniff"},
                               {"X-Frame-Options", "DENY"},
                               {"Cross-Origin-Opener-Policy", "same-origin"}});
    http->set_pre_routing_handler([this](const httplib::Request& request, httplib::Response& response) {
      if (request.method != "GET" && request.method != "HEAD" && !same_origin(request)) {
        response.status = 403;
        response.set_content(web::error_json("cross-origin request refused (Origin \"" + request.get_header_value("Origin") +
                                                 "\" is not this page's)", "PERMISSION_DENIED"),
                             "application/json");
        return httplib::Server::HandlerResponse::Handled;
      }
      if (request.path.rfind("/api/", 0) == 0 && !logged_in(request)) {
        response.status = 401;
        response.set_content(web::error_json("log in first", "UNAUTHENTICATED"), "application/json");
        return httplib::Server::HandlerResponse::Handled;
      }
      return httplib::Server::HandlerResponse::Unhandled;
    });
    http->Post("/login", [this](const httplib::Request& q, httplib::Response& r) { login(q, r); });
    http->Post("/logout", [this](const httplib::Request& q, httplib::Response& r) { logout(q, r); });
    http->Get("/api/whoami", [](const httplib::Request&, httplib::Response& r) {
      r.set_header("Cache-Control", "no-store");
      r.set_content("{\"logged_in\":true}", "application/json");
    });
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
      event_stream(q, r, "CameraService", "StreamPreview", message.dump());
    });
    http->Get("/api/stream/events", [this](const httplib::Request& q, httplib::Response& r) {
      event_stream(q, r, "EventService", "Subscribe", "{}");
    });
    http->Post(R"(/api/([A-Za-z0-9]+)/([A-Za-z0-9]+))", [this](const httplib::Request& q, httplib::Response& r) {
      const web::BridgeReply reply = bridge.call(q.matches[1], q.matches[2], q.body);
      r.status = reply.http_status;
      r.set_header("Cache-Control", "no-store");
      r.set_content(reply.json, "application/json");
    });
    // A session's own files (maps.exr, previews, summary.json, the journal):
    // only inside that session's folder, after log-in (the pre-routing check).
    http->Get(R"(/api/files/([A-Za-z0-9_-][A-Za-z0-9_.-]{0,127})/(.+))", [this](const httplib::Request& q, httplib::Response& r) {
      const std::string id = q.matches[1], relative = q.matches[2];
      const auto file = static_file(config.sessions_dir / id, "/" + relative);
      if (!file) {
        r.status = 404;
        r.set_content(web::error_json("no file \"" + relative.substr(0, 256) + "\" in session \"" + id + "\"", "NOT_FOUND"),
                      "application/json");
        return;
      }
      serve_file(*file, r);
      r.set_header("Cache-Control", "no-store");
    });
    http->Get(R"(/.*)", [this](const httplib::Request& q, httplib::Response& r) {
      const auto file = static_file(config.web_dir, q.path);
      if (!file) {
        r.status = 404;
        r.set_content("not found: " + q.path.substr(0, 256) + "\n", "text/plain; charset=utf-8");
        return;
      }
      serve_file(*file, r);
      r.set_header("Cache-Control", file->extension() == ".html" ? "no-store" : "no-cache");
    });
  }
};

WebServer::WebServer(const DaemonConfig& config, std::shared_ptr<grpc::Channel> api_channel, WebAuditor audit)
    : state_(std::make_unique<State>(config, std::move(api_channel), std::move(audit))) {
  if (config.web_address.empty()) throw std::invalid_argument("web_address: not set");
  if (config.web_dir.empty() || !fs::is_directory(config.web_dir))
    throw std::runtime_error("web_dir: \"" + config.web_dir.string() + "\" is not a folder (build the front end: docs/web.md)");
  if (!config.tls_certificate_file.empty()) {
    state_->tls = true;
    state_->http = std::make_unique<httplib::SSLServer>(config.tls_certificate_file.c_str(), config.tls_private_key_file.c_str());
    if (!state_->http->is_valid()) throw std::runtime_error("web_address: cannot use the TLS certificate and key");
  } else {
    state_->http = std::make_unique<httplib::Server>();
  }
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
