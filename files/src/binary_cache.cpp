#include "chromo/files/binary_cache.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <regex>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include "chromo/files/durable_file.hpp"
#include "chromo/files/fnv1a.hpp"

namespace chromo::files {
namespace fs = std::filesystem;

namespace {

// The fields before the payload (the layout in binary_cache.hpp).
struct Header {
  std::array<char, 8> magic;
  std::uint32_t version;
  std::uint64_t key;
  std::uint64_t payload_bytes;
};
constexpr std::size_t kHeaderBytes = 8 + 4 + 8 + 8;
constexpr std::size_t kChecksumBytes = 8;

std::uint64_t checksum_of(std::span<const std::uint8_t> payload) {
  Fnv1a hash;
  hash.add(payload.data(), payload.size());
  return hash.h;
}

template <class T>
bool read_value(std::ifstream& in, T& value) {
  return static_cast<bool>(in.read(reinterpret_cast<char*>(&value), sizeof value));
}

std::uint64_t initial_cache_limit() {
  if (const char* text = std::getenv("CHROMO_CACHE_LIMIT_BYTES"); text && *text) {
    char* end = nullptr;
    const unsigned long long value = std::strtoull(text, &end, 10);
    if (end && *end == '\0' && value > 0) return value;
  }
  return kDefaultCacheLimitBytes;
}

std::atomic<std::uint64_t>& limit_holder() {
  static std::atomic<std::uint64_t> limit{initial_cache_limit()};
  return limit;
}

bool is_cache_file_name(const std::string& name) {
  static const std::regex pattern("[A-Za-z0-9_]+_[0-9a-f]{16}\\.bin");
  return std::regex_match(name, pattern);
}

}  // namespace

std::uint64_t cache_limit_bytes() { return limit_holder().load(); }
void set_cache_limit_bytes(std::uint64_t limit) { limit_holder().store(limit); }

std::uint64_t trim_cache_folder(const fs::path& dir, std::uint64_t limit_bytes, const fs::path& keep) {
  struct Entry {
    fs::path path;
    fs::file_time_type used;
    std::uintmax_t bytes;
  };
  std::vector<Entry> entries;
  std::uint64_t total = 0;
  std::error_code error;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    if (!is_cache_file_name(it->path().filename().string())) continue;
    std::error_code e;
    if (!it->is_regular_file(e) || e) continue;
    const auto bytes = it->file_size(e);
    const auto used = it->last_write_time(e);
    if (e) continue;
    total += bytes;
    if (!keep.empty() && it->path().filename() == keep.filename()) continue;
    entries.push_back({it->path(), used, bytes});
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.used < b.used; });
  std::uint64_t removed = 0;
  for (const auto& entry : entries) {
    if (total <= limit_bytes) break;
    std::error_code e;
    if (fs::remove(entry.path, e)) {  // another process may have removed it already
      total -= entry.bytes;
      removed += entry.bytes;
    } else if (!e) {
      total -= entry.bytes;
    }
  }
  return removed;
}

std::string cache_key_hex(std::uint64_t key) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(key));
  return hex;
}

std::string cache_file_name(const std::string& stem, std::uint64_t key) { return stem + "_" + cache_key_hex(key) + ".bin"; }

std::optional<std::vector<std::uint8_t>> read_cache(const fs::path& file, const CacheFormat& format,
                                                    std::uint64_t key, std::string* why) {
  auto miss = [&](const std::string& reason) -> std::optional<std::vector<std::uint8_t>> {
    if (why) *why = reason;
    return std::nullopt;
  };
  std::error_code error;
  const std::uintmax_t file_bytes = fs::file_size(file, error);
  if (error) return miss("cannot read it (" + error.message() + ")");
  std::ifstream in(file, std::ios::binary);
  Header header;
  const std::string magic(format.magic.data(), format.magic.size());
  if (!read_value(in, header.magic) || header.magic != format.magic)
    return miss("another kind of file (its magic is not " + magic + ")");
  if (!read_value(in, header.version) || !read_value(in, header.key) || !read_value(in, header.payload_bytes))
    return miss("truncated header");
  if (header.version != format.version)
    return miss("another format version (" + std::to_string(header.version) + ", this build reads " +
                std::to_string(format.version) + ")");
  if (header.key != key) return miss("another key");
  if (file_bytes < kHeaderBytes + kChecksumBytes || header.payload_bytes != file_bytes - kHeaderBytes - kChecksumBytes)
    return miss("truncated, extended or with a corrupted length (its header says " +
                std::to_string(header.payload_bytes) + " payload bytes, the file holds " + std::to_string(file_bytes) +
                " bytes in all)");
  std::vector<std::uint8_t> payload(header.payload_bytes);
  std::uint64_t checksum = 0;
  if (!in.read(reinterpret_cast<char*>(payload.data()), static_cast<std::streamsize>(payload.size())) ||
      !read_value(in, checksum) || in.peek() != std::char_traits<char>::eof())
    return miss("truncated while it was read");
  if (checksum != checksum_of(payload)) return miss("checksum mismatch (corrupted bytes)");
  // Used now: the least recently used files are the ones a bounded folder loses first.
  fs::last_write_time(file, fs::file_time_type::clock::now(), error);
  if (why) why->clear();
  return payload;
}

void write_cache(const fs::path& file, const CacheFormat& format, std::uint64_t key,
                 std::span<const std::uint8_t> payload) {
  if (file.has_parent_path()) {
    std::error_code error;
    fs::create_directories(file.parent_path(), error);
    if (error) throw std::runtime_error("cache " + file.string() + ": cannot create its folder (" + error.message() + ")");
  }
  const Header header{format.magic, format.version, key, payload.size()};
  const std::uint64_t checksum = checksum_of(payload);
  commit_file_durably(file, nullptr, [&](const fs::path& temporary) {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(header.magic.data(), sizeof header.magic);
    out.write(reinterpret_cast<const char*>(&header.version), sizeof header.version);
    out.write(reinterpret_cast<const char*>(&header.key), sizeof header.key);
    out.write(reinterpret_cast<const char*>(&header.payload_bytes), sizeof header.payload_bytes);
    out.write(reinterpret_cast<const char*>(payload.data()), static_cast<std::streamsize>(payload.size()));
    out.write(reinterpret_cast<const char*>(&checksum), sizeof checksum);
    out.close();
    if (!out) throw std::runtime_error("cache " + file.string() + ": cannot write " + temporary.string());
  });
  trim_cache_folder(file.has_parent_path() ? file.parent_path() : fs::path("."), cache_limit_bytes(), file);
}

}  // namespace chromo::files
