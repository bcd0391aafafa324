#include "chromo/files/float_image.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <ImfThreading.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <mutex>
#include <optional>
#include <thread>
#include <string_view>
#include <utility>

#include "chromo/files/bounded_read.hpp"

namespace chromo::files {

const std::vector<float>& FloatImage::channel(const std::string& name) const {
  for (std::size_t i = 0; i < channel_names.size(); ++i)
    if (channel_names[i] == name) return channels[i];
  std::string have;
  for (const auto& n : channel_names) have += (have.empty() ? "" : ", ") + n;
  throw ImageError("image has no channel '" + name + "' (it has " + have + ")");
}

const std::string* FloatImage::attribute(const std::string& name) const {
  for (const auto& [key, value] : attributes)
    if (key == name) return &value;
  return nullptr;
}

namespace {
// The header attributes FloatImage carries: string-typed, named "chromo.*".
bool carried_attribute(const std::string& name) { return name.rfind("chromo.", 0) == 0; }
}  // namespace

namespace {

// OpenEXR's compression codes: NONE 0, RLE 1, ZIPS 2, ZIP 3, PIZ 4, PXR24 5,
// B44 6, B44A 7 are lossless for FLOAT data; DWAA 8 and DWAB 9 are lossy.
constexpr int kLastLosslessCompression = 7;
constexpr int kDwabCompression = 9;

// The most raw pixel bytes one stored byte can stand for, over the lossless
// compressions: deflate (ZIP, ZIPS) cannot exceed 1032:1, PXR24 first packs
// 32-bit floats into 24 bits then deflates (1032 · 4/3 = 1376); PIZ's Huffman
// run codes reach about 410:1, RLE 64:1 (a 2-byte run of at most 128 bytes),
// B44A 32:3 on flat HALF blocks.
constexpr double kMaxExrExpansion = 1376.0;

// Bytes per pixel of a chlist attribute: per channel a name, an int32 pixel
// type (UINT 0, HALF 1, FLOAT 2), four bytes (pLinear, reserved) and the
// int32 x and y sampling; a null name ends the list.
template <typename Fail>
double chlist_bytes_per_pixel(std::string_view list, const Fail& fail) {
  auto int32_at = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(list[at + static_cast<std::size_t>(i)]);
    return static_cast<std::int32_t>(v);
  };
  double bytes = 0;
  std::size_t at = 0;
  while (true) {
    const std::size_t end = list.find('\0', at);
    if (end == std::string_view::npos) throw fail("channel list unterminated");
    if (end == at) break;
    at = end + 1;
    if (list.size() - at < 16) throw fail("channel list truncated");
    const std::int32_t type = int32_at(at), x_sampling = int32_at(at + 8), y_sampling = int32_at(at + 12);
    if (type < 0 || type > 2) throw fail("channel pixel type " + std::to_string(type) + " (0-2 are known)");
    if (x_sampling < 1 || y_sampling < 1) throw fail("channel sampling below 1");
    bytes += (type == 1 ? 2.0 : 4.0) / (static_cast<double>(x_sampling) * static_cast<double>(y_sampling));
    at += 16;
  }
  // OpenEXR reads a channel list up to its null name, not by its declared
  // size: the two must end together or its reading and ours part ways.
  if (at + 1 != list.size()) throw fail("channel list's size does not match its entries");
  return bytes;
}

// OpenEXR reads an attribute of a known fixed-size type by its type, not by
// the size the file declares, so a size that differs would make its reading
// of the header part from this one, and it would then take the next bytes as
// an attribute size it allocates (found by fuzz_exr: a 36-byte `float`).
// Returns the size a type must have; 0 for the variable-size types, which
// OpenEXR reads by the declared size (string, stringvector, floatvector,
// unknown types) or which are checked on their own (chlist, preview).
std::size_t fixed_attribute_size(const std::string& type) {
  static const std::pair<const char*, std::size_t> kSizes[] = {
      {"box2i", 16}, {"box2f", 16},   {"compression", 1},     {"double", 8},  {"envmap", 1},  {"float", 4},
      {"int", 4},    {"keycode", 28}, {"lineOrder", 1},       {"m33f", 36},   {"m33d", 72},   {"m44f", 64},
      {"m44d", 128}, {"rational", 8}, {"tiledesc", 9},        {"timecode", 8}, {"v2i", 8},    {"v2f", 8},
      {"v2d", 16},   {"v3i", 12},     {"v3f", 12},            {"v3d", 24},    {"chromaticities", 32},
      {"deepImageState", 1}};
  for (const auto& [name, size] : kSizes)
    if (type == name) return size;
  return 0;
}

}  // namespace

ExrSize check_exr_file(const std::filesystem::path& path) {
  try {
    check_regular_file(path, kMaxImageFileBytes, "OpenEXR");
  } catch (const InputFileError& e) {
    throw ImageError(e.what());
  }
  // The header is read by hand, bounded, before OpenEXR sees the file: the
  // library sizes its line tables from the data window as it opens a file.
  constexpr std::size_t kMaxHeaderBytes = 1 << 20;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ImageError(path.string() + ": cannot open");
  std::string head(kMaxHeaderBytes, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  auto fail = [&](const std::string& what) -> ImageError { return ImageError(path.string() + ": not a readable OpenEXR file: " + what); };
  auto int32_at = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(head[at + static_cast<std::size_t>(i)]);
    return static_cast<std::int32_t>(v);
  };
  if (head.size() < 8 || std::memcmp(head.data(), "\x76\x2f\x31\x01", 4) != 0) throw fail("no OpenEXR magic number");
  const auto flags = static_cast<std::uint32_t>(int32_at(4));
  if ((flags & 0xff) != 2) throw fail("version " + std::to_string(flags & 0xff) + " (only 2 is known)");
  if (flags & 0x800) throw fail("deep data is not supported");
  if (flags & 0x1000) throw fail("multi-part files are not supported");
  std::size_t at = 8;
  auto read_string = [&](const char* what) {
    const std::size_t end = head.find('\0', at);
    if (end == std::string::npos || end - at > 255) throw fail(std::string("header ") + what + " unterminated or longer than the first 1 MiB");
    std::string s = head.substr(at, end - at);
    at = end + 1;
    return s;
  };
  std::optional<ExrSize> size;
  std::optional<int> compression;
  double stored_bytes_per_pixel = 0;  // over every channel, with its sampling
  while (true) {
    const std::string name = read_string("attribute name");
    if (name.empty()) break;
    const std::string type = read_string("attribute type");
    if (at + 4 > head.size()) throw fail("header attribute '" + name + "' truncated");
    const std::int32_t length = int32_at(at);
    at += 4;
    if (length < 0 || static_cast<std::size_t>(length) > head.size() - at)
      throw fail("header attribute '" + name + "' size " + std::to_string(length) + " runs past the header");
    if (name == "dataWindow") {
      if (type != "box2i" || length != 16) throw fail("dataWindow is not a box2i");
      const std::int64_t x0 = int32_at(at), y0 = int32_at(at + 4), x1 = int32_at(at + 8), y1 = int32_at(at + 12);
      size = ExrSize{x1 - x0 + 1, y1 - y0 + 1};
    } else if (name == "compression") {
      if (type != "compression" || length != 1) throw fail("compression is not a one-byte compression attribute");
      compression = static_cast<unsigned char>(head[at]);
    } else if (name == "channels") {
      if (type != "chlist") throw fail("channels is not a chlist");
      stored_bytes_per_pixel = chlist_bytes_per_pixel(std::string_view(head).substr(at, static_cast<std::size_t>(length)), fail);
    }
    if (const std::size_t fixed = fixed_attribute_size(type); fixed != 0 && static_cast<std::size_t>(length) != fixed)
      throw fail("header attribute '" + name + "' of type " + type + " has size " + std::to_string(length) + ", not " +
                 std::to_string(fixed));
    if (type == "preview") {
      // Two uint32 (width, height), then width × height RGBA bytes: OpenEXR
      // allocates by the dimensions, so they must account for the size.
      if (length < 8) throw fail("preview attribute truncated");
      const std::uint64_t width = static_cast<std::uint32_t>(int32_at(at)), height = static_cast<std::uint32_t>(int32_at(at + 4));
      const auto pixel_bytes = static_cast<std::uint64_t>(length) - 8;
      if ((width != 0 && height > pixel_bytes / 4 / width) || 4 * width * height != pixel_bytes)
        throw fail("preview size does not match its dimensions");
    }
    if (type == "chlist" && name != "channels")
      chlist_bytes_per_pixel(std::string_view(head).substr(at, static_cast<std::size_t>(length)), fail);
    at += static_cast<std::size_t>(length);
  }
  if (!size) throw fail("no dataWindow in the header");
  try {
    check_image_size(path, size->width, size->height);
  } catch (const InputFileError& e) {
    throw ImageError(e.what());
  }
  if (!compression) throw fail("no compression in the header");
  if (*compression > kLastLosslessCompression)
    throw fail(*compression <= kDwabCompression
                   ? "DWAA/DWAB compression is lossy and has no bound on its expansion; store maps losslessly"
                   : "unknown compression " + std::to_string(*compression));
  // The pixel data this header declares must fit in what the file holds at
  // the densest packing any lossless OpenEXR compression reaches: otherwise
  // the file is truncated or forged, and reading it would first allocate
  // (and fill) the whole declared image for nothing (found by fuzz_exr: a
  // 250-byte file declaring a 16-MP row).
  const double declared_bytes = stored_bytes_per_pixel * static_cast<double>(size->width) * static_cast<double>(size->height);
  const auto file_bytes = static_cast<double>(std::filesystem::file_size(path));
  if (declared_bytes > kMaxExrExpansion * file_bytes)
    throw fail("the header declares " + std::to_string(static_cast<std::uint64_t>(declared_bytes)) +
               " bytes of pixels, more than " + std::to_string(static_cast<int>(kMaxExrExpansion)) +
               " times the file's " + std::to_string(static_cast<std::uint64_t>(file_bytes)) +
               " bytes (no lossless compression packs denser): truncated or not an image");
  return *size;
}

FloatImage read_exr(const std::filesystem::path& path) {
  check_exr_file(path);
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    FloatImage image;
    image.width = window.max.x - window.min.x + 1;
    image.height = window.max.y - window.min.y + 1;
    Imf::FrameBuffer frame;
    const std::size_t pixels = static_cast<std::size_t>(image.width) * image.height;
    for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it)
      image.channel_names.push_back(it.name());
    for (auto it = file.header().begin(); it != file.header().end(); ++it)
      if (const auto* text = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()); text && carried_attribute(it.name()))
        image.attributes.emplace_back(it.name(), text->value());
    // The 64-MP cap bounds one channel; this bounds them all together before
    // any pixel memory: at most kMaxImageValues floats (1 GiB).
    if (pixels * image.channel_names.size() > kMaxImageValues)
      throw ImageError(path.string() + ": " + std::to_string(image.channel_names.size()) + " channels of " +
                       std::to_string(pixels) + " pixels exceed the cap of " + std::to_string(kMaxImageValues) +
                       " values");
    image.channels.resize(image.channel_names.size());
    for (auto& channel : image.channels) channel.resize(pixels);
    // Slice::Make places the buffer at the data window's origin in 64-bit
    // arithmetic: a window far from (0, 0) (found by fuzz_exr: min.y of
    // -84215046) must not overflow an int computing the base pointer.
    for (std::size_t c = 0; c < image.channel_names.size(); ++c)
      frame.insert(image.channel_names[c], Imf::Slice::Make(Imf::FLOAT, image.channels[c].data(), window, sizeof(float),
                                                            sizeof(float) * static_cast<std::size_t>(image.width)));
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    return image;
  } catch (const std::exception& e) {
    throw ImageError(path.string() + ": cannot read as OpenEXR: " + e.what());
  }
}

ExrHeader read_exr_header(const std::filesystem::path& path) {
  const ExrSize size = check_exr_file(path);
  try {
    Imf::InputFile file(path.c_str());
    ExrHeader header{static_cast<int>(size.width), static_cast<int>(size.height), {}};
    for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it)
      header.channel_names.push_back(it.name());
    return header;
  } catch (const std::exception& e) {
    throw ImageError(path.string() + ": cannot read as OpenEXR: " + e.what());
  }
}

int exr_writer_threads(int threads) {
  if (threads < 0) throw std::invalid_argument("EXR writer threads: " + std::to_string(threads) + " (0 = all cores, 1 = one)");
  return threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

namespace {

// OpenEXR compresses a file's line blocks as tasks on its one global thread
// pool, which has no thread until asked (globalThreadCount() is 0): the pool
// grows to the most threads any write asked for and never shrinks.
void ensure_exr_pool(int threads) {
  static std::mutex mutex;
  const std::lock_guard lock(mutex);
  if (Imf::globalThreadCount() < threads) Imf::setGlobalThreadCount(threads);
}

}  // namespace

void write_exr(const std::filesystem::path& path, const FloatImage& image, const ExrWriteOptions& options) {
  const int threads = exr_writer_threads(options.threads);
  if (options.zip_level < -1 || options.zip_level > 9)
    throw std::invalid_argument("EXR zip_level: " + std::to_string(options.zip_level) + " (-1 = OpenEXR's default, 0-9)");
  try {
    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    if (options.zip_level >= 0) header.zipCompressionLevel() = options.zip_level;
    for (const auto& name : image.channel_names) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    for (const auto& [name, value] : image.attributes) {
      if (!carried_attribute(name)) throw std::invalid_argument("attribute '" + name + "' is not named chromo.*");
      header.insert(name, Imf::StringAttribute(value));
    }
    // One thread: the caller's alone (no pool task), as before threading.
    if (threads > 1) ensure_exr_pool(threads);
    Imf::OutputFile file(path.c_str(), header, threads > 1 ? threads : 0);
    Imf::FrameBuffer frame;
    for (std::size_t c = 0; c < image.channel_names.size(); ++c)
      frame.insert(image.channel_names[c],
                   Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(image.channels[c].data())),
                              sizeof(float), sizeof(float) * image.width));
    file.setFrameBuffer(frame);
    file.writePixels(image.height);
  } catch (const std::exception& e) {
    throw ImageError(path.string() + ": cannot write OpenEXR: " + e.what());
  }
}

}  // namespace chromo::files
