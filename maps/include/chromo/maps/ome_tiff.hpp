#pragma once
// Maps and frames as OME-TIFF, the format Fiji, napari and Python's tifffile
// open without a plugin (docs/maps.md, "Opening the maps"):
//
//   maps.ome.tiff  beside every maps.exr: one float32 plane per channel of the
//                  map image, whatever channels it holds (Cm, Ch, Bm, Che,
//                  residual, order, flags, and surface/highlight or sigma_*
//                  when present): Cm, Ch, Bm, Che, residual, order, flags
//                  first, then the sigma_* channels, then any other in the
//                  image's order (maps.exr reads back sorted by name, so a
//                  file exported from it has the same order). The OME-XML (the first
//                  page's ImageDescription) names each channel; a
//                  MapAnnotation (namespace kOmeMapsNamespace) gives each
//                  channel's unit ("unit:<channel>") and meaning
//                  ("meaning:<channel>") and each flag code's name
//                  ("flag:<code>"); PhysicalSizeX/Y in µm when known.
//   frames-<camera>.ome.tiff  (`chromo export --frames`) a session's raw
//                  frames of one camera as a stack along T at their stored
//                  bit depth; each Plane carries DeltaT (s since the first
//                  frame) and ExposureTime (µs), the MapAnnotation each
//                  plane's step, role, illumination (LED drive levels) and
//                  host time ("plane:<t>:<field>").
//
// Pages are tiled (256 × 256), Deflate-compressed (zlib format by libdeflate,
// no predictor, so a reader without imagecodecs reads them), little-endian,
// classic TIFF (BigTIFF past 4 GB). The tiles are compressed on `threads` threads and written in
// order. The writers write to the path they are given: callers make them
// durable (files::commit_file_durably, or the estimate report's FileCommit).
// Errors: std::invalid_argument for a malformed image (sizes, channels),
// std::runtime_error naming the file when libtiff fails.
//
// Thread rules: free functions, reentrant.

#include <filesystem>
#include <string>
#include <vector>

#include "chromo/files/float_image.hpp"
#include "chromo/session/frame_record.hpp"

namespace chromo::maps {

inline constexpr const char* kOmeMapsNamespace = "chromosphere.org/maps/v1";

// A map channel's unit and meaning by its name: the parameters' volume
// fractions, βm's share, the residual's albedo RMS, the order's model, the
// flags' codes, "sigma_X" as X's unit; "" for a channel this table does not know.
struct MapChannelInfo {
  std::string name, unit, meaning;
};
MapChannelInfo map_channel_info(const std::string& name);
// The order maps are written and sent in (maps.exr reads back sorted by
// name): indices into `names` for Cm, Ch, Bm, Che, residual, order, flags,
// then the sigma_* channels, then the others, each group in its given order.
std::vector<std::size_t> map_channel_order(const std::vector<std::string>& names);

struct OmeTiffOptions {
  double pixel_size_um = 0;  // on the subject; 0 = unknown (PhysicalSize left out)
  int threads = 0;           // tile compression threads; 0 = all cores
  int zip_level = 1;         // deflate level 1-9
};

// The maps image as maps.ome.tiff (the layout above).
void write_maps_ome_tiff(const std::filesystem::path& path, const files::FloatImage& maps,
                         const OmeTiffOptions& options = {});
// The OME-XML write_maps_ome_tiff puts in the file (exposed for tests).
std::string maps_ome_xml(const files::FloatImage& maps, const OmeTiffOptions& options);

// One camera's frames of a stored session as one OME-TIFF stack. `records`
// must all be of one camera, size and pixel format (8 or 16 bits, one
// sample): std::invalid_argument naming the frame otherwise. Each frame is
// read from session_folder / record.file (the bounded TIFF reader).
void write_frames_ome_tiff(const std::filesystem::path& path, const std::filesystem::path& session_folder,
                           const std::vector<session::FrameRecord>& records, const OmeTiffOptions& options = {});

}  // namespace chromo::maps
