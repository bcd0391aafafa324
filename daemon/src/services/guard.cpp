// The services' Guard (authentication) and their id and name checks.
#include "services.hpp"

namespace chromo::daemon::services {

Status Guard::authenticate(ServerContext* context) const {
  const std::string peer = context->peer();
  if (peer.rfind("unix:", 0) == 0) return Status::OK;
  if (config_.token.empty()) return {StatusCode::UNAUTHENTICATED, "this daemon accepts no TCP calls"};
  const auto& metadata = context->client_metadata();
  auto found = metadata.find("authorization");
  if (found == metadata.end()) return {StatusCode::UNAUTHENTICATED, "authorization: missing bearer token"};
  const std::string value(found->second.data(), found->second.size());
  const std::string expected = "Bearer " + config_.token;
  // Constant-time comparison.
  unsigned char difference = value.size() == expected.size() ? 0 : 1;
  for (std::size_t i = 0; i < value.size() && i < expected.size(); ++i)
    difference |= static_cast<unsigned char>(value[i] ^ expected[i]);
  if (difference != 0) return {StatusCode::UNAUTHENTICATED, "authorization: wrong bearer token"};
  return Status::OK;
}

Status check_id(const std::string& field, const std::string& id) {
  if (id.empty()) return invalid(field + ": required");
  if (id.size() > 128) return invalid(field + ": longer than 128 bytes");
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
