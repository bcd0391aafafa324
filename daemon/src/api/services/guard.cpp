// The services' Guard (authentication, the stream limit, the audit log), the
// callers' identities and the id and name checks.
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstring>

#include <cstdio>

#include "chromo/files/durable_file.hpp"
#include "chromo/files/fnv1a.hpp"
#include "services.hpp"

namespace chromo::daemon::services {

namespace {

bool is_unix_peer(const std::string& peer) { return peer.rfind("unix:", 0) == 0 || peer.rfind("fd:", 0) == 0; }

}  // namespace

void Peers::accepted(int fd, unsigned uid) {
  std::lock_guard lock(mutex_);
  uid_by_fd_[fd] = uid;
}

Status check_bearer(const DaemonConfig& config, const std::multimap<grpc::string_ref, grpc::string_ref>& metadata) {
  if (config.token.empty()) return {StatusCode::UNAUTHENTICATED, "this daemon accepts no TCP calls"};
  auto found = metadata.find("authorization");
  if (found == metadata.end()) return {StatusCode::UNAUTHENTICATED, "authorization: missing bearer token"};
  const std::string value(found->second.data(), found->second.size());
  const std::string expected = "Bearer " + config.token;
  // Constant-time comparison.
  unsigned char difference = value.size() == expected.size() ? 0 : 1;
  for (std::size_t i = 0; i < value.size() && i < expected.size(); ++i)
    difference |= static_cast<unsigned char>(value[i] ^ expected[i]);
  if (difference != 0) return {StatusCode::UNAUTHENTICATED, "authorization: wrong bearer token"};
  return Status::OK;
}

std::string token_id(const std::string& token) {
  files::Fnv1a hash;
  hash.add(token.data(), token.size());
  char hex[9];
  std::snprintf(hex, sizeof hex, "%08x", static_cast<unsigned>(hash.h >> 32));
  return hex;
}

std::string Peers::who(const ServerContext& context) const {
  const std::string peer = context.peer();
  if (!is_unix_peer(peer)) return "token:" + token_id_;  // TCP: only the one token gets past authentication
  if (peer.rfind("fd:", 0) == 0) {
    int fd = -1;
    try {
      fd = std::stoi(peer.substr(3));
    } catch (const std::exception&) {
      return "unknown";
    }
    std::lock_guard lock(mutex_);
    if (auto found = uid_by_fd_.find(fd); found != uid_by_fd_.end()) return "uid:" + std::to_string(found->second);
  }
  return "unknown";
}

void AuditLog::record(const std::string& who, const std::string& action, const Status& outcome,
                      const nlohmann::json& details) {
  nlohmann::json line = nlohmann::json::object();
  const auto now = std::chrono::system_clock::now();
  line["time_ms"] = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count();
  line["who"] = who;
  line["action"] = action;
  for (const auto& [key, value] : details.items()) line[key] = value;
  line["outcome"] = outcome.ok() ? "ok" : "refused";
  if (!outcome.ok()) {
    line["code"] = static_cast<int>(outcome.error_code());
    line["error"] = outcome.error_message();
  }
  const std::string text = line.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  std::lock_guard lock(mutex_);
  const bool created = !std::filesystem::exists(file_);
  // O_APPEND: every line goes to the end, nothing written is ever overwritten.
  const int fd = ::open(file_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0640);
  if (fd < 0) throw std::runtime_error(file_.string() + ": cannot open (" + std::strerror(errno) + ")");
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string reason = std::strerror(errno);
      ::close(fd);
      throw std::runtime_error(file_.string() + ": cannot append (" + reason + ")");
    }
    written += static_cast<std::size_t>(n);
  }
  try {
    files::fsync_or_throw(fd, file_.string());
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
  if (created) files::fsync_directory(file_.parent_path());
}

Status Guard::authenticate(ServerContext* context) const {
  // TCP calls reach a handler only past the credentials' token processor
  // (server.cpp), before their message is parsed; checked again here.
  if (is_unix_peer(context->peer())) return Status::OK;
  return check_bearer(config_, context->client_metadata());
}

Status check_id(const std::string& field, const std::string& id) {
  if (id.empty()) return invalid(field + ": required");
  if (id.size() > 128) return invalid(field + ": longer than 128 bytes");
  if (id == "." || id == "..") return invalid(field + ": not an id");
  if (!session::is_valid_name(id) && id.size() <= session::kMaxNameBytes) return invalid(field + ": not an id ([A-Za-z0-9_+.-])");
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '+' || c == '.' || c == '-'))
      return invalid(field + ": not an id ([A-Za-z0-9_+.-])");
  return Status::OK;
}

Status check_device_name(const std::string& field, const std::string& name) {
  if (name.size() > 128) return invalid(field + ": longer than 128 bytes");
  return Status::OK;
}

}  // namespace chromo::daemon::services
