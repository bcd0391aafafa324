#pragma once
// Tables of radial reflectance profiles for renderers, and per-pixel index
// maps into them (format: docs/formats/profiles.md).
//
// A ProfileTable holds one RadialProfile (radial_profile.hpp) per point of a
// rectangular grid over (Cm, Ch, βm, Che), in linear sRGB under one
// illuminant. A renderer looks up a pixel's profile by the index map that
// nearest_entry_indices() makes from the estimator's parameter maps.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "chromo/files/output_batch.hpp"
#include "chromo/files/progress.hpp"
#include "chromo/maps/discrepancy_layer.hpp"
#include "chromo/maps/radial_profile.hpp"

namespace chromo::maps {

struct ProfileTableAxes {
  std::vector<double> cm, ch, bm, che;  // each strictly increasing and inside MODEL.md's ranges

  // 8 Cm × 8 Ch (log-spaced over the ranges) × 3 βm × 3 Che = 576 profiles.
  static ProfileTableAxes Default();
  bool IsValid(std::string* error) const;
  std::size_t entry_count() const { return cm.size() * ch.size() * bm.size() * che.size(); }
};

struct ProfileTable {
  std::string illuminant;  // as the caller named it (d65, a, FILE.csv ...)
  ProfileTableAxes axes;
  std::vector<double> radius_mm;
  // [entry][radius][rgb], entry = ((i_cm·|Ch| + i_ch)·|βm| + i_bm)·|Che| + i_che.
  std::vector<float> profiles_rgb_per_mm2;
  std::vector<float> albedo_rgb;  // [entry][rgb], from the forward model
  double worst_plane_integral_error = 0;  // max over entries and channels of |∫R 2πr dr / albedo - 1|

  std::size_t entry_index(std::size_t i_cm, std::size_t i_ch, std::size_t i_bm, std::size_t i_che) const {
    return ((i_cm * axes.ch.size() + i_ch) * axes.bm.size() + i_bm) * axes.che.size() + i_che;
  }
};

// Throws std::invalid_argument when the axes are not valid. Progress
// (files/progress.hpp): reported from the calling thread with the fraction of
// entries done and "profile table", and 1 at the end; cancelled() is polled
// on the calling thread after each entry it computes, and then
// build_profile_table throws files::Cancelled once the entries under way are done.
ProfileTable build_profile_table(const RadialProfileModel& model, const ProfileTableAxes& axes,
                                 const std::string& illuminant_name, int threads = 0,
                                 const files::Progress& progress = {});

// Adds profiles.json and profiles.f32 to `files` (written to temporaries;
// they appear in the batch's directory, crash-safe, at files.commit()).
void write_profile_table(files::OutputBatch& files, const ProfileTable& table);

// estimation::Estimator maps as `chromo estimate` writes them (maps.exr: float channels
// Cm, Ch, Bm, Che and flags), and the relit layer "model + discrepancy" where
// the maps carry it (discrepancy_layer.hpp; maps written before it have none).
struct ParameterMaps {
  int width = 0, height = 0;
  std::vector<float> cm, ch, bm, che, flags;
  std::optional<DiscrepancyLayer> discrepancy{};
};
// Throws std::runtime_error naming the file and what is missing or malformed
// (a discrepancy layer without its basis, or a basis that does not match it).
ParameterMaps read_parameter_maps(const std::filesystem::path& maps_exr);

inline constexpr std::uint32_t kNoProfileEntry = 0xFFFFFFFFu;
// Nearest table entry per pixel (in log space for Cm and Ch, linear for βm
// and Che); kNoProfileEntry where the pixel is flagged or not finite.
std::vector<std::uint32_t> nearest_entry_indices(const ProfileTable& table, const ParameterMaps& maps);
// index.exr in `files`: one UINT channel "entry", same size as the maps.
void write_index_map(files::OutputBatch& files, const ParameterMaps& maps, const std::vector<std::uint32_t>& indices);

}  // namespace chromo::maps
