#pragma once
// The photographs a relight can be compared against (MapsService.Relight's
// photograph_file; the web view's picker): the OpenEXR files of a folder
// that hold R, G and B channels, each with its size and whether it has the
// maps' size (Relight refuses any other).

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace chromo::maps {

struct PhotographFile {
  std::string file;          // relative to the folder, '/'-separated
  int width = 0, height = 0;
  bool same_size = false;    // width × height equal the maps'
};

// Walks `folder` (at most `max_entries` directory entries, hidden names and
// symbolic links skipped: nothing outside the folder is read) and returns
// its *.exr files with R, G and B channels, sorted by path; files that are
// not readable OpenEXR are left out. Throws std::invalid_argument when
// `folder` is not a folder.
std::vector<PhotographFile> list_photograph_files(const std::filesystem::path& folder, int maps_width, int maps_height,
                                                  std::size_t max_entries = 10000);

}  // namespace chromo::maps
