#include "chromo/files/bounded_read.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace chromo::files {
namespace {

std::string kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

[[noreturn]] void refuse(const std::filesystem::path& path, const std::string& what) {
  throw InputFileError(path.string() + ": " + what);
}

void check_stat(const std::filesystem::path& path, const struct stat& st, std::uintmax_t cap_bytes,
                std::string_view what) {
  if (!S_ISREG(st.st_mode))
    refuse(path, "not a regular file (" + kind_of(st.st_mode) + "); " + std::string(what) +
                     " files must be regular files");
  if (static_cast<std::uintmax_t>(st.st_size) > cap_bytes)
    refuse(path, std::to_string(st.st_size) + " bytes, over the " + describe_bytes(cap_bytes) + " cap for " +
                     std::string(what) + " files");
}

}  // namespace

std::string describe_bytes(std::uintmax_t bytes) {
  if (bytes >= (1ull << 30) && bytes % (1ull << 30) == 0) return std::to_string(bytes >> 30) + " GiB";
  if (bytes >= (1ull << 20) && bytes % (1ull << 20) == 0) return std::to_string(bytes >> 20) + " MiB";
  if (bytes >= (1ull << 10) && bytes % (1ull << 10) == 0) return std::to_string(bytes >> 10) + " KiB";
  return std::to_string(bytes) + " bytes";
}

void check_regular_file(const std::filesystem::path& path, std::uintmax_t cap_bytes, std::string_view what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) refuse(path, "cannot open (" + std::string(std::strerror(errno)) + ")");
  check_stat(path, st, cap_bytes, what);
}

std::string read_bounded(const std::filesystem::path& path, std::uintmax_t cap_bytes, std::string_view what) {
  // Checked by name first, so a FIFO is refused without blocking in open();
  // checked again on the open descriptor, so a swap in between is caught.
  check_regular_file(path, cap_bytes, what);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) refuse(path, "cannot open (" + std::string(std::strerror(errno)) + ")");
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) refuse(path, "cannot stat (" + std::string(std::strerror(errno)) + ")");
  check_stat(path, st, cap_bytes, what);
  std::string text;
  text.resize(static_cast<std::size_t>(st.st_size));
  std::size_t have = 0;
  while (true) {
    if (have == text.size()) {
      if (text.size() > cap_bytes) break;
      text.resize(std::min<std::uintmax_t>(cap_bytes + 1, text.size() + 65536));
    }
    const ssize_t n = ::read(fd, text.data() + have, text.size() - have);
    if (n < 0) {
      if (errno == EINTR) continue;
      refuse(path, "read failed (" + std::string(std::strerror(errno)) + ")");
    }
    if (n == 0) break;
    have += static_cast<std::size_t>(n);
  }
  if (have > cap_bytes)
    refuse(path, "grew past the " + describe_bytes(cap_bytes) + " cap for " + std::string(what) +
                     " files while being read");
  text.resize(have);
  return text;
}

void check_image_size(const std::filesystem::path& path, std::int64_t width, std::int64_t height) {
  if (width <= 0 || height <= 0)
    refuse(path, "image size " + std::to_string(width) + "×" + std::to_string(height) + " is not positive");
  // Both are bounded by int64; compare without overflow.
  if (width > static_cast<std::int64_t>(kMaxImagePixels) || height > static_cast<std::int64_t>(kMaxImagePixels) ||
      static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height) > kMaxImagePixels)
    refuse(path, "image size " + std::to_string(width) + "×" + std::to_string(height) + " is over the " +
                     std::to_string(kMaxImagePixels / 1000000) + " MP cap per image");
}

std::string read_png_file(const std::filesystem::path& path) {
  std::string bytes = read_bounded(path, kMaxPngFileBytes, "PNG");
  static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kSignature, 8) != 0)
    refuse(path, "not a PNG file (no PNG signature; images other than OpenEXR must be PNG)");
  // The first chunk must be IHDR: length 13, "IHDR", width and height big-endian.
  if (bytes.size() < 8 + 8 + 13 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0)
    refuse(path, "not a PNG file (no IHDR chunk first)");
  auto be32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(bytes[at + i]);
    return v;
  };
  if (be32(8) != 13) refuse(path, "not a PNG file (IHDR length " + std::to_string(be32(8)) + ", 13 expected)");
  check_image_size(path, be32(16), be32(20));
  return bytes;
}

}  // namespace chromo::files
