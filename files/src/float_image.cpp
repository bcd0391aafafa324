#include "chromo/files/float_image.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>

#include <algorithm>

namespace chromo::files {

const std::vector<float>& FloatImage::channel(const std::string& name) const {
  for (std::size_t i = 0; i < channel_names.size(); ++i)
    if (channel_names[i] == name) return channels[i];
  std::string have;
  for (const auto& n : channel_names) have += (have.empty() ? "" : ", ") + n;
  throw ImageError("image has no channel '" + name + "' (it has " + have + ")");
}

FloatImage read_exr(const std::filesystem::path& path) {
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
    image.channels.assign(image.channel_names.size(), std::vector<float>(pixels));
    for (std::size_t c = 0; c < image.channel_names.size(); ++c) {
      char* base = reinterpret_cast<char*>(image.channels[c].data() - window.min.x - window.min.y * image.width);
      frame.insert(image.channel_names[c],
                   Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * image.width));
    }
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    return image;
  } catch (const std::exception& e) {
    throw ImageError(path.string() + ": cannot read as OpenEXR: " + e.what());
  }
}

void write_exr(const std::filesystem::path& path, const FloatImage& image) {
  try {
    Imf::Header header(image.width, image.height);
    for (const auto& name : image.channel_names) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    Imf::OutputFile file(path.c_str(), header);
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
