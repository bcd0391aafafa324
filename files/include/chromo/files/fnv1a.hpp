#pragma once
// FNV-1a, 64 bit, byte by byte: the project's one hash. The key of an
// on-disk cache (forward table, inverse table, rendered session) over
// everything the cached content depends on, and the checksum of a cache
// file's payload (binary_cache.hpp). Not cryptographic: it tells inputs
// apart and catches corrupted bytes, it does not authenticate files.

#include <cstddef>
#include <cstdint>

namespace chromo::files {

struct Fnv1a {
  std::uint64_t h = 1469598103934665603ull;
  void add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
  // Trivially copyable values only (their bytes are hashed).
  template <class T>
  void add(const T& v) { add(&v, sizeof v); }
};

}  // namespace chromo::files
