// exr_dump MAPS.exr OUT: the EXR's channels as OUT.json ({"width", "height",
// "channels"}) and OUT.f32 (float32, little-endian, channel after channel,
// rows top to bottom), so a Python test compares another file's values with
// maps.exr's (Debian has no Python OpenEXR). Exit 2 on a bad file.
#include <fstream>
#include <iostream>

#include <nlohmann/json.hpp>

#include "chromo/files/float_image.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: exr_dump MAPS.exr OUT\n";
    return 2;
  }
  try {
    const auto image = chromo::files::read_exr(argv[1]);
    std::ofstream(std::string(argv[2]) + ".json")
        << nlohmann::json{{"width", image.width}, {"height", image.height}, {"channels", image.channel_names}}.dump();
    std::ofstream raw(std::string(argv[2]) + ".f32", std::ios::binary);
    for (const auto& channel : image.channels)
      raw.write(reinterpret_cast<const char*>(channel.data()), static_cast<std::streamsize>(channel.size() * sizeof(float)));
    return raw.flush() ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "exr_dump: " << e.what() << "\n";
    return 2;
  }
}
