#pragma once
// The one reader of data files (CSV, JSON, EXR, TIFF, PNG) for the CLI, the
// configuration and the API. A data file must be a regular file (not a FIFO,
// a device, a socket or a directory: /dev/zero never ends, a FIFO blocks) and
// within a documented cap; an image's size is checked from its header before
// any pixel memory is allocated. Device paths belong in device settings only.
//
// Every refusal throws InputFileError naming the path and what was wrong
// ("/dev/zero: not a regular file (character device)", "big.csv: 17000000
// bytes, over the 16 MiB cap for CSV files"). Thread rules: free functions,
// reentrant.

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

namespace chromo::files {

class InputFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Documented defaults (docs/formats/README.md, "Limits").
inline constexpr std::uintmax_t kMaxTextFileBytes = 16ull << 20;     // one CSV or JSON file: 16 MiB
inline constexpr std::uint64_t kMaxImagePixels = 64ull * 1000 * 1000;  // one image: 64 MP (width × height)
inline constexpr std::uint64_t kMaxImageValues = 256ull << 20;  // one float image's channels × pixels: 1 GiB of floats
inline constexpr std::uintmax_t kMaxImageFileBytes = 2ull << 30;      // one EXR or TIFF file on disk: 2 GiB
inline constexpr std::uintmax_t kMaxPngFileBytes = 256ull << 20;      // one PNG file (read whole): 256 MiB
// A session's journal is the daemon's own record of every frame it accepted:
// never refused at the data-file cap (about 300 bytes a frame record, so 16
// MiB would be ~50,000 frames), only at 4 GiB, far beyond any session.
inline constexpr std::uintmax_t kMaxJournalBytes = 4ull << 30;

// Throws InputFileError unless `path` names an existing regular file (symbolic
// links are followed) of at most `cap_bytes` bytes; `what` names the kind of
// file in the message ("CSV", "JSON", "LED library").
void check_regular_file(const std::filesystem::path& path, std::uintmax_t cap_bytes, std::string_view what);

// Reads a whole data file: checks it as above, then reads at most
// cap_bytes + 1 bytes, so a file that grows while it is read is refused too.
std::string read_bounded(const std::filesystem::path& path, std::uintmax_t cap_bytes, std::string_view what);

// CSV and JSON files: read_bounded with kMaxTextFileBytes.
inline std::string read_text_file(const std::filesystem::path& path, std::string_view what) {
  return read_bounded(path, kMaxTextFileBytes, what);
}

// Throws InputFileError naming the path unless width and height are positive
// and width × height ≤ kMaxImagePixels.
void check_image_size(const std::filesystem::path& path, std::int64_t width, std::int64_t height);

// A PNG file read whole for a decoder (cv::imdecode): a regular file within
// kMaxPngFileBytes, with a PNG signature and an IHDR chunk whose width and
// height pass check_image_size, all before any decoder sees it. Any other
// format is refused naming the path.
std::string read_png_file(const std::filesystem::path& path);

// "16 MiB", "64 MP": the caps as the messages and docs say them.
std::string describe_bytes(std::uintmax_t bytes);

}  // namespace chromo::files
