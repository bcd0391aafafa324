#include "maps_folder.hpp"

#include <cmath>
#include <ctime>
#include <mutex>
#include <random>

#include "chromo/files/bounded_read.hpp"

namespace chromo::daemon::services::maps_api {

namespace fs = std::filesystem;
using grpc::Status;
using grpc::StatusCode;

std::string api_message(const std::string& message) {
  static const std::pair<const char*, const char*> kNames[] = {
      {"maps: ", "maps_file: "},         {"photograph: ", "photograph_file: "},
      {"mask: ", "mask_file: "},         {"melanin: ", "melanin_file: "},
      {"hemoglobin: ", "hemoglobin_file: "}, {"measurement: ", "measurement_file: "},
      {"out: ", "out_dir: "},           {"statistics_mask: ", "statistics_mask_file: "}};
  for (const auto& [library, api] : kNames)
    if (message.rfind(library, 0) == 0) return api + message.substr(std::string(library).size());
  return message;
}

Folder::Folder(Daemon& daemon, const std::string& session_id) {
  if (session_id.empty()) {
    if (daemon.config().maps_dir.empty())
      throw Refusal{{StatusCode::INVALID_ARGUMENT,
                     "session_id: required (this daemon has no maps_dir for work without a session)"}};
    fs::create_directories(daemon.config().maps_dir);
    base_ = fs::canonical(daemon.config().maps_dir);
    what_ = "maps_dir";
    return;
  }
  if (Status s = check_id("session_id", session_id); !s.ok()) throw Refusal{s};
  if (!daemon.session(session_id))
    throw Refusal{{StatusCode::NOT_FOUND, "session_id: no session \"" + session_id + "\""}};
  base_ = fs::canonical(daemon.config().sessions_dir / session_id);
  what_ = "the session folder";
}

fs::path Folder::input(const std::string& field, const std::string& value, bool required) const {
  if (value.empty()) {
    if (required) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": required"}};
    return {};
  }
  if (value.size() > kMaxPathBytes) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": longer than 4096 bytes"}};
  if (value.find('\0') != std::string::npos) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": contains NUL"}};
  const fs::path path(value);
  if (path.is_absolute())
    throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": must be a path relative to " + what_ + ", not absolute"}};
  for (const auto& part : path)
    if (part == "..") throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": must not contain \"..\""}};
  // Every symbolic link on the way must resolve completely, and inside: a
  // link out of the folder reads as the same refusal whether its target
  // exists, is unreadable or is missing.
  const auto outside = [&] { return Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + value + " leads outside " + what_}}; };
  std::error_code error;
  fs::path prefix = base_;
  for (const auto& part : path) {
    prefix /= part;
    if (fs::is_symlink(fs::symlink_status(prefix, error))) {
      const fs::path target = fs::canonical(prefix, error);
      if (error || !inside(target)) throw outside();
    }
  }
  const fs::path resolved = fs::weakly_canonical(base_ / path, error);
  if (error || !inside(resolved)) throw outside();
  const auto status = fs::status(resolved, error);
  if (error || !fs::exists(status)) throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + value + ": no such file"}};
  if (!fs::is_regular_file(status))
    throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + value + ": not a regular file"}};
  return resolved;
}

fs::path Folder::output(const std::string& operation, const std::string& label) const {
  if (!label.empty() && !session::is_valid_name(label))
    throw Refusal{{StatusCode::INVALID_ARGUMENT, "label: must match [A-Za-z0-9_+.-]{1,64}"}};
  const fs::path products = base_ / "products";
  std::error_code error;
  const auto status = fs::symlink_status(products, error);
  if (fs::exists(status) && !fs::is_directory(status))
    throw Refusal{{StatusCode::FAILED_PRECONDITION, "products: exists in " + what_ + " and is not a folder"}};
  static std::mutex mutex;
  static std::mt19937_64 random{std::random_device{}()};
  std::uint64_t suffix;
  {
    std::lock_guard lock(mutex);
    suffix = random();
  }
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  ::gmtime_r(&now, &utc);
  char name[64];
  std::snprintf(name, sizeof name, "%04d%02d%02dT%02d%02d%02dZ-%06llx", utc.tm_year + 1900, utc.tm_mon + 1, utc.tm_mday,
                utc.tm_hour, utc.tm_min, utc.tm_sec, static_cast<unsigned long long>(suffix & 0xffffff));
  fs::path out = products / (operation + "-" + name + (label.empty() ? "" : "-" + label));
  if (fs::exists(out, error)) throw Refusal{{StatusCode::ABORTED, "out_dir: " + relative(out) + " exists; retry"}};
  return out;
}

std::string Folder::scrub(std::string message) const {
  const std::string prefix = base_.string() + "/";
  for (std::size_t at; (at = message.find(prefix)) != std::string::npos;) message.erase(at, prefix.size());
  return message;
}

bool Folder::inside(const fs::path& path) const {
  auto b = base_.begin(), p = path.begin();
  for (; b != base_.end(); ++b, ++p)
    if (p == path.end() || *p != *b) return false;
  return true;
}

// Illuminant and camera names that are files follow the input rule; names do not.
std::string name_or_file(const Folder& folder, const char* field, const std::string& value, const char* fallback) {
  if (value.empty()) return fallback;
  if (value.size() > kMaxPathBytes) throw Refusal{{StatusCode::INVALID_ARGUMENT, std::string(field) + ": longer than 4096 bytes"}};
  const bool looks_like_file = value.find('/') != std::string::npos || value.find('.') != std::string::npos;
  return looks_like_file ? folder.input(field, value, true).string() : value;
}

double scale_field(double value, const char* field) {
  if (value == 0) return 1.0;
  if (!(value > 0) || !std::isfinite(value)) throw Refusal{{StatusCode::INVALID_ARGUMENT, std::string(field) + ": must be > 0"}};
  return value;
}

std::shared_ptr<const chromo::files::FloatImage> read_maps_file(chromo::files::DecodedExrCache& cache, const Folder& files,
                                                                 const std::string& maps_file,
                                                                 const std::string& field) {
  try {
    return cache.read(files.input(field, maps_file, true));
  } catch (const chromo::files::ImageError& e) {
    throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + files.scrub(e.what())}};
  } catch (const chromo::files::InputFileError& e) {
    throw Refusal{{StatusCode::INVALID_ARGUMENT, field + ": " + files.scrub(e.what())}};
  }
}

}  // namespace chromo::daemon::services::maps_api
