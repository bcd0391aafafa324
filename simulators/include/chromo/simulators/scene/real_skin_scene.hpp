#pragma once
// A scene of real skin for `chromo estimate`: measured albedo spectra (the
// NIST forearms shipped with the estimation library, or any table of
// spectra), one square patch per spectrum with a faint texture, ink and
// marker on top, photographed under a plan's illuminants through a camera
// with its noise; written as a MEASUREMENT.json folder
// (docs/formats/measurement.md). The estimator has never seen these spectra
// unless it was taught them: hold subjects out when judging it.
//
//   albedo(x, λ) = S_p(λ) · (1 + texture · t(x)) · A(x, λ)
// S_p the patch's spectrum, t uniform in [−1, 1] per pixel, A the anomaly
// factor (synthetic.hpp: tattoo ink in a disc, a green marker stroke across
// the patches, or 1). No subsurface spread: every pixel's light leaves where
// it entered.
//
// Camera: builtin:nikon_d5100; noise per image: four frames of a
// 40,000 e⁻ sensor (synthetic.hpp's model, 160,000 e⁻ at full scale, 12 e⁻
// read) times noise_scale (0: noise-free, declared at the nominal noise).
// Plans: "method" (R, G, B under D65' + B under the blue LED) or
// "six-leds" (R, G, B under each LED type alone).
//
// Files: MEASUREMENT.json, one EXR and illuminant CSV per image, truth.exr
// (spectrum index, texture scale, region: 0 skin, 1 tattoo, 2 marker),
// skin_mask.png (255 on skin at least 2 px inside its patch).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "chromo/estimation/model_discrepancy.hpp"

namespace chromo::simulators {

struct RealSkinSceneOptions {
  std::vector<estimation::NamedSpectrum> spectra;  // one patch each
  int patch_px = 32;
  int columns = 5;                                 // patches per row
  std::string plan = "method";                     // "method" or "six-leds"
  double texture_relative = 0.03;
  double noise_scale = 1.0;
  bool anomalies = true;                           // the ink disc and the marker stroke
  std::uint64_t seed = 1;
  int threads = 0;
  bool IsValid(std::string* error) const;
};

// Throws std::invalid_argument for invalid options (naming the field),
// std::runtime_error when writing fails. Writes atomically (files::OutputBatch).
void write_real_skin_scene(const std::filesystem::path& directory, const RealSkinSceneOptions& options);

// The named subjects of nist_forearm_spectra(): "041-050" (a range of subject
// numbers) or "001,007,013"; std::invalid_argument naming an unknown one.
std::vector<estimation::NamedSpectrum> nist_subjects(const std::string& selection);

}  // namespace chromo::simulators
