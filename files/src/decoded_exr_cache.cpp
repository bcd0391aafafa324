#include "chromo/files/decoded_exr_cache.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

namespace chromo::files {

DecodedExrCache::Stamp DecodedExrCache::stamp_of(const std::filesystem::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw ImageError("cannot read " + path.string() + ": " + std::strerror(errno));
  return {static_cast<std::uintmax_t>(st.st_size),
          static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec,
          static_cast<std::uint64_t>(st.st_ino)};
}

std::shared_ptr<const FloatImage> DecodedExrCache::read(const std::filesystem::path& path) {
  const std::string key = path.lexically_normal().string();
  const Stamp stamp = stamp_of(path);
  {
    std::lock_guard lock(mutex_);
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->path != key) continue;
      if (it->stamp == stamp) {
        entries_.splice(entries_.begin(), entries_, it);
        return it->image;
      }
      bytes_ -= it->bytes;
      entries_.erase(it);  // changed: decoded again below
      break;
    }
  }
  Entry entry{key, stamp, std::make_shared<const FloatImage>(read_exr(path)), 0};
  for (const auto& channel : entry.image->channels) entry.bytes += channel.size() * sizeof(float);
  std::lock_guard lock(mutex_);
  ++decodes_;
  auto image = entry.image;
  if (entry.bytes <= max_bytes_) insert_locked(std::move(entry));
  return image;
}

void DecodedExrCache::insert_locked(Entry entry) {
  for (auto it = entries_.begin(); it != entries_.end(); ++it)
    if (it->path == entry.path) {  // another reader decoded it meanwhile
      bytes_ -= it->bytes;
      entries_.erase(it);
      break;
    }
  bytes_ += entry.bytes;
  entries_.push_front(std::move(entry));
  while (bytes_ > max_bytes_ && !entries_.empty()) {
    bytes_ -= entries_.back().bytes;
    entries_.pop_back();
  }
}

std::uint64_t DecodedExrCache::bytes() const {
  std::lock_guard lock(mutex_);
  return bytes_;
}
std::size_t DecodedExrCache::entries() const {
  std::lock_guard lock(mutex_);
  return entries_.size();
}
std::uint64_t DecodedExrCache::decodes() const {
  std::lock_guard lock(mutex_);
  return decodes_;
}

}  // namespace chromo::files
