// OpenEXR float images through files::read_exr: the project's own header
// check (regular file, data window ≤ 64 MP, single-part, not deep) runs
// before OpenEXR (a Debian library) reads the file. Documented error:
// files::ImageError.
#include <cstdint>

#include "chromo/files/float_image.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = chromo::fuzz::write_input("image.exr", data, size);
  try {
    const auto image = chromo::files::read_exr(path);
    if (!image.channel_names.empty()) (void)image.channel(image.channel_names.front());
  } catch (const chromo::files::ImageError&) {
  }
  return 0;
}
