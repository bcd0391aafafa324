#pragma once
// Test data for `chromo import-maps` (and `maps::relight`, `flush`): the virtual
// lab's skin scene (make_skin_scene, no white strip) measured the method's
// way, plus "another device's" relative melanin and hemoglobin maps made from
// the scene's truth through a monotone nonlinearity the importer is NOT told:
//
//   melanin    = 60000 · (1 − exp(−Cm / 0.06))^0.7 + 600 · n1
//   hemoglobin = 60000 · sqrt(Ch / (Ch + 0.04)) · (1 + 0.05·(βm − 0.7)) + 600 · n2
//
// as 16-bit PNGs (n1, n2 standard Gaussian per pixel, i.e. 1% of full scale;
// the βm factor is a small crosstalk, as a real device's is not a pure
// concentration). Under tattoo, marker, hair and specular regions the maps
// still show the skin underneath, as a device that sees past them would not:
// there the imported maps are simply wrong for the photograph.
//
// Files written into the directory (crash-safe through files::OutputBatch):
//   MEASUREMENT.json, d65prime.exr (R, G, B under a D65 metamer of the six
//   LEDs), blue.exr (B under the blue LED), d65prime.csv, blue.csv,
//   truth.exr (Cm, Ch, Bm, Che, flags = 0, region), melanin.png, hemoglobin.png,
//   skin_mask.png (255 where the region is plain skin: import-maps --stats-mask).
// Camera: builtin:nikon_d5100; noise: Gaussian with synthetic.hpp's camera
// model variance (σ² = read² + shot·albedo + step²/12) times
// camera_noise_scale² (0 = noise-free). MEASUREMENT.json states the nominal
// (scale 1) noise either way.

#include <cstdint>
#include <filesystem>

namespace chromo::simulators {

struct ExternalMapsSceneOptions {
  int width = 192, height = 144;
  std::uint64_t seed = 7;
  double camera_noise_scale = 0.25;  // a mean of 16 frames (the daemon's derived albedo averages frames)
  double map_noise_fraction = 0.01;  // σ of the imported maps' noise, fraction of full scale
  int threads = 0;
  // A second session of the same subject: another draw of the noise (0: from
  // seed) and Ch scaled in a rectangle (SkinSceneOptions::ch_factor; truth.exr has it).
  std::uint64_t noise_seed = 0;
  double ch_factor = 1;
  int ch_change_x = 0, ch_change_y = 0, ch_change_width = 0, ch_change_height = 0;
};

// Throws std::invalid_argument for bad options, std::runtime_error when writing fails.
void write_external_maps_scene(const std::filesystem::path& directory, const ExternalMapsSceneOptions& options);

}  // namespace chromo::simulators
