// A session's TIFF frames through session::read_tiff: regular file, image
// size checked against 64 MP and the layout against the pixel format before
// any pixel buffer, then libtiff (a Debian library). Documented error:
// std::runtime_error (files::InputFileError is one).
#include <tiffio.h>

#include <cstdint>
#include <stdexcept>

#include "chromo/session/frame_files.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  TIFFSetWarningHandler(nullptr);  // libtiff's chatter on malformed input
  TIFFSetErrorHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = chromo::fuzz::write_input("frame.tiff", data, size);
  try {
    (void)chromo::session::read_tiff(path);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
