#pragma once
// The maps file of a stored session as the `chromo maps` commands name it:
// a maps.exr given itself, SESSION/maps.exr (a `chromo estimate --out`
// folder), SESSION/results/maps.exr, or with a camera
// SESSION/results/<camera>/maps.exr.

#include <filesystem>
#include <string>

#include "chromo/files/float_image.hpp"

namespace chromo::cli {

// The file; std::invalid_argument starting with `what` ("before", or the
// path) when there is none.
std::filesystem::path maps_file_of(const std::filesystem::path& input, const std::string& camera);

// The file read; std::invalid_argument naming the file when it is not a readable OpenEXR.
files::FloatImage read_maps_of(const std::filesystem::path& input, const std::string& camera, const std::string& what);

}  // namespace chromo::cli
