#pragma once
// MEASUREMENT.json (docs/formats/measurement.md): the captures of one subject
// as linear-albedo OpenEXR images with their illuminants, camera and noise.
// Read by `chromo estimate` and `chromo import-maps` (and the daemon's maps
// service). Everything is read and checked here; nothing is written.

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "chromo/files/float_image.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/session/registration.hpp"

namespace chromo::session {

// Bad input: the message names the file and the key (images[1]: channel "X" ...).
class MeasurementFileError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

struct MeasurementImage {
  std::string name;
  files::FloatImage pixels;
  std::vector<std::string> channels;  // camera channels used: "R", "G", "B"
  spectral::Spectrum illuminant;
  estimation::ChannelNoise noise;
};

struct MeasurementFile {
  spectral::CameraSensitivity camera;
  std::vector<MeasurementImage> images;
  int width = 0, height = 0;

  // One channel per (image, listed camera channel), in file order.
  estimation::MeasurementSet measurement_set() const;
  // Pixel-major values in measurement_set() order.
  std::vector<float> pixel_major() const;
};

// "builtin:<name>" (spectral::builtin_camera) or a CSV path relative to `base`.
spectral::CameraSensitivity camera_by_name_or_file(const std::string& text, const std::filesystem::path& base);

// At most this many channels (the listed camera channels of all images
// together, so at most this many images), checked before any image is read:
// the largest built-in plan (multispectral+method) has 27. One file listing
// an image 1000 times reached 15.5 GB before.
inline constexpr std::size_t kMaxMeasurementChannels = 32;

// Throws MeasurementFileError for anything wrong with the file or what it names.
MeasurementFile read_measurement_file(const std::filesystem::path& json_file);

// Registers every image after the first to images[0] (ECC on the first
// channel both list, else the image's first) and warps it in place when it
// moved significantly (motion_is_significant), with `options` (the
// defaults: chromo estimate's).
// Throws RegistrationError naming the image.
std::vector<RegistrationReport> register_images(MeasurementFile& measurement, const RegistrationOptions& options = {});

}  // namespace chromo::session
