#pragma once
// A study's region masks (docs/study.md "Regions"): `--region NAME=PATH`
// names a part of the skin (a cheek, a patch before and after treatment) by
// a mask image per session: PATH is relative to each session's folder (or
// absolute), "{camera}" in it is replaced by the camera's name; the file is
// an 8-bit PNG at the maps' size (the measurement's: half the sensor's per
// side), non-zero inside. The table then holds each parameter's statistics
// over the explained skin inside the mask as well.
//
// Thread rules: free functions.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace chromo::cli::study {

struct RegionSpec {
  std::string name;  // 1-32 of A-Z a-z 0-9 _ -
  std::string path;  // as given
};

// "NAME=PATH"; std::invalid_argument naming the option otherwise (or a name given twice).
std::vector<RegionSpec> parse_regions(const std::vector<std::string>& options);
std::vector<std::string> region_options(const std::vector<RegionSpec>& regions);  // back to NAME=PATH

// Where a camera's mask of a session is.
std::filesystem::path region_mask_file(const std::filesystem::path& session_folder, const RegionSpec& region,
                                       const std::string& camera);
// Every file a region may use in a session (the study's input hash): the
// mask of each camera whose frames the session holds.
std::vector<std::filesystem::path> region_input_files(const std::filesystem::path& session_folder,
                                                      const RegionSpec& region);

// The mask, width × height values (non-zero inside). std::invalid_argument
// naming the file when it cannot be read or is not that size.
std::vector<std::uint8_t> read_region_mask(const std::filesystem::path& file, int width, int height);

}  // namespace chromo::cli::study
