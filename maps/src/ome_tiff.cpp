#include "chromo/maps/ome_tiff.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <stdexcept>

#include "chromo/estimation/pixel_flags.hpp"
#include "chromo/session/frame_files.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/spectral/led_type.hpp"
#include "tiled_tiff_writer.hpp"

namespace chromo::maps {

namespace {

std::string xml_escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// OME-XML's frame: one Image with its Pixels and one MapAnnotation.
struct OmeImage {
  std::string name, type;  // type: "float", "uint16", "uint8"
  int width = 0, height = 0, size_c = 1, size_t = 1;
  double pixel_size_um = 0;
  std::vector<std::string> channel_names;
  std::vector<std::string> planes;                            // <Plane .../> elements
  std::vector<std::pair<std::string, std::string>> annotation;  // MapAnnotation's key/value pairs
};

std::string ome_xml(const OmeImage& image) {
  std::string x = R"(<?xml version="1.0" encoding="UTF-8"?>)";
  x += "\n";
  x += R"(<OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06" )"
       R"(xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" )"
       R"(xsi:schemaLocation="http://www.openmicroscopy.org/Schemas/OME/2016-06 )"
       R"(http://www.openmicroscopy.org/Schemas/OME/2016-06/ome.xsd" Creator="chromosphere">)";
  x += fmt::format(R"(<Image ID="Image:0" Name="{}">)", xml_escape(image.name));
  x += fmt::format(R"(<Pixels ID="Pixels:0" DimensionOrder="XYCZT" Type="{}" SizeX="{}" SizeY="{}" SizeC="{}" )"
                   R"(SizeZ="1" SizeT="{}" BigEndian="false" Interleaved="false")",
                   image.type, image.width, image.height, image.size_c, image.size_t);
  if (image.pixel_size_um > 0)  // µm is PhysicalSize's default unit
    x += fmt::format(R"( PhysicalSizeX="{:.6g}" PhysicalSizeY="{:.6g}")", image.pixel_size_um, image.pixel_size_um);
  x += ">";
  for (std::size_t c = 0; c < image.channel_names.size(); ++c)
    x += fmt::format(R"(<Channel ID="Channel:0:{}" Name="{}" SamplesPerPixel="1"/>)", c, xml_escape(image.channel_names[c]));
  x += fmt::format(R"(<TiffData IFD="0" PlaneCount="{}"/>)", image.size_c * image.size_t);
  for (const auto& plane : image.planes) x += plane;
  x += R"(</Pixels><AnnotationRef ID="Annotation:0"/></Image>)";
  x += fmt::format(R"(<StructuredAnnotations><MapAnnotation ID="Annotation:0" Namespace="{}"><Value>)", kOmeMapsNamespace);
  for (const auto& [key, value] : image.annotation)
    x += fmt::format(R"(<M K="{}">{}</M>)", xml_escape(key), xml_escape(value));
  x += "</Value></MapAnnotation></StructuredAnnotations></OME>";
  return x;
}

bool needs_big_tiff(std::uint64_t raw_bytes) { return raw_bytes > 3'500'000'000ull; }

}  // namespace

// Known channels by their rank in the list, then sigma_* in their parameter's
// order, then the rest (stable): the same order whether the names come as
// written or as an EXR reads them back (alphabetically).
std::vector<std::size_t> map_channel_order(const std::vector<std::string>& names) {
  static const std::vector<std::string> first = {"Cm", "Ch", "Bm", "Che", "residual", "order", "flags"};
  auto rank = [&](const std::string& name) {
    const auto at = std::find(first.begin(), first.end(), name);
    if (at != first.end()) return static_cast<int>(at - first.begin());
    if (name.rfind("sigma_", 0) == 0) {
      const auto of = std::find(first.begin(), first.end(), name.substr(6));
      return 100 + static_cast<int>(of - first.begin());
    }
    return 200;
  };
  std::vector<std::size_t> order(names.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return rank(names[a]) < rank(names[b]); });
  return order;
}

MapChannelInfo map_channel_info(const std::string& name) {
  static const std::map<std::string, std::pair<std::string, std::string>> known = {
      {"Cm", {"volume fraction", "melanin volume fraction in the epidermis"}},
      {"Ch", {"volume fraction", "hemoglobin (blood) volume fraction in the dermis"}},
      {"Bm", {"fraction", "eumelanin share of melanin (betam)"}},
      {"Che", {"volume fraction", "hemoglobin volume fraction in the epidermis"}},
      {"residual", {"albedo RMS", "RMS over the measurement channels of measured minus modelled albedo"}},
      {"order", {"model order", "model the pixel was fitted with: 0 none, 2 the 2D model (Cm, Ch), 4 the 4D model"}},
      {"flags", {"flag code", "why the model does not explain the pixel; 0 explained (codes: flag:<code>)"}},
      {"surface", {"albedo", "surface reflection from the parallel and cross polarised captures (information only)"}},
      {"highlight", {"albedo", "specular highlight from the polarised captures (information only)"}},
      {"corr_Ch_Che", {"correlation", "correlation of Ch and Che in the fit's covariance (near +-1: the data cannot separate them)"}},
  };
  if (name.rfind("discrepancy_", 0) == 0)
    return {name, "albedo", "coefficient of the pixel's posterior discrepancy on basis spectrum b" + name.substr(12) +
                                " (annotation chromo.discrepancy_basis); relit albedo = model + sum_k c_k b_k"};
  if (const auto it = known.find(name); it != known.end()) return {name, it->second.first, it->second.second};
  if (name.rfind("sigma_", 0) == 0) {
    const MapChannelInfo of = map_channel_info(name.substr(6));
    if (!of.unit.empty()) return {name, of.unit, "standard deviation of " + of.name};
  }
  return {name, "", ""};
}

std::string maps_ome_xml(const files::FloatImage& maps, const OmeTiffOptions& options) {
  const std::vector<std::size_t> order = map_channel_order(maps.channel_names);
  OmeImage image;
  image.name = "chromophore maps";
  image.type = "float";
  image.width = maps.width, image.height = maps.height;
  image.size_c = static_cast<int>(maps.channel_names.size());
  image.pixel_size_um = options.pixel_size_um;
  for (std::size_t c : order) image.channel_names.push_back(maps.channel_names[c]);
  for (const auto& name : image.channel_names) {
    const MapChannelInfo info = map_channel_info(name);
    image.annotation.emplace_back("unit:" + name, info.unit);
    image.annotation.emplace_back("meaning:" + name, info.meaning);
  }
  for (int f = 0; f < estimation::kPixelFlagCount; ++f)
    image.annotation.emplace_back(fmt::format("flag:{}", f),
                                  std::string(estimation::pixel_flag_name(static_cast<estimation::PixelFlag>(f))));
  image.annotation.emplace_back("source", "chromosphere estimate (docs/maps.md)");
  // maps.exr's header attributes (the discrepancy layer's basis), under their own names.
  for (const auto& [name, value] : maps.attributes) image.annotation.emplace_back(name, value);
  return ome_xml(image);
}

void write_maps_ome_tiff(const std::filesystem::path& path, const files::FloatImage& maps,
                         const OmeTiffOptions& options) {
  const auto pixels = static_cast<std::size_t>(maps.width) * static_cast<std::size_t>(maps.height);
  if (maps.width <= 0 || maps.height <= 0 || maps.channels.empty() ||
      maps.channels.size() != maps.channel_names.size())
    throw std::invalid_argument(fmt::format("maps OME-TIFF: {}x{} image with {} channels and {} names", maps.width,
                                            maps.height, maps.channels.size(), maps.channel_names.size()));
  for (std::size_t c = 0; c < maps.channels.size(); ++c)
    if (maps.channels[c].size() != pixels)
      throw std::invalid_argument(fmt::format("maps OME-TIFF: channel {} has {} values for {} pixels",
                                              maps.channel_names[c], maps.channels[c].size(), pixels));
  const std::string xml = maps_ome_xml(maps, options);
  detail::TiledTiffWriter writer(path, needs_big_tiff(pixels * 4 * maps.channels.size()), options.zip_level,
                                 options.threads);
  for (std::size_t c : map_channel_order(maps.channel_names))
    writer.add_page(maps.channels[c].data(), maps.width, maps.height, detail::SampleType::kFloat32, xml);
  writer.finish();
}

void write_frames_ome_tiff(const std::filesystem::path& path, const std::filesystem::path& session_folder,
                           const std::vector<session::FrameRecord>& records, const OmeTiffOptions& options) {
  if (records.empty()) throw std::invalid_argument("frames OME-TIFF: no frames");
  const session::FrameRecord& first = records.front();
  const auto& format = drivers::pixel_format_info(first.pixel_format);
  if (format.samples_per_pixel != 1)
    throw std::invalid_argument(fmt::format("frames OME-TIFF: camera {}: {} frames have {} samples per pixel (one expected)",
                                            first.camera, format.name, format.samples_per_pixel));
  OmeImage image;
  image.name = "frames of " + first.camera;
  image.type = format.bytes_per_sample == 1 ? "uint8" : "uint16";
  image.width = first.width, image.height = first.height;
  image.size_t = static_cast<int>(records.size());
  image.pixel_size_um = options.pixel_size_um;
  image.channel_names = {first.camera + " " + std::string(format.name)};
  image.annotation.emplace_back("camera", first.camera);
  image.annotation.emplace_back("pixel_format", std::string(format.name));
  image.annotation.emplace_back("significant_bits", std::to_string(format.significant_bits));
  for (std::size_t t = 0; t < records.size(); ++t) {
    const session::FrameRecord& r = records[t];
    if (r.camera != first.camera || r.width != first.width || r.height != first.height ||
        r.pixel_format != first.pixel_format)
      throw std::invalid_argument(fmt::format("frames OME-TIFF: frame {} ({}) differs from the first frame of camera {} "
                                              "in camera, size or pixel format",
                                              r.index, r.file, first.camera));
    const double delta_s = static_cast<double>(r.host_timestamp_ns - first.host_timestamp_ns) * 1e-9;
    image.planes.push_back(fmt::format(R"(<Plane TheC="0" TheZ="0" TheT="{}" DeltaT="{:.9g}" ExposureTime="{:.9g}"/>)", t,
                                       delta_s, r.exposure_us * 1e-6));
    const std::string key = fmt::format("plane:{}:", t);
    image.annotation.emplace_back(key + "file", r.file);
    image.annotation.emplace_back(key + "step", r.step);
    image.annotation.emplace_back(key + "role", session::role_name(r.role));
    image.annotation.emplace_back(key + "exposure_us", fmt::format("{:.9g}", r.exposure_us));
    image.annotation.emplace_back(key + "host_time_ns", std::to_string(r.host_timestamp_ns));
    std::string drive;
    if (r.led)
      for (std::size_t k = 0; k < spectral::kAllLedTypes.size(); ++k)
        drive += fmt::format("{}{}={:.6g}", drive.empty() ? "" : ",", spectral::led_type_name(spectral::kAllLedTypes[k]),
                             r.led->drive[k]);
    image.annotation.emplace_back(key + "illumination", drive.empty() ? "unknown" : drive);
  }
  const std::string xml = ome_xml(image);
  const std::uint64_t raw = static_cast<std::uint64_t>(format.frame_bytes(first.width, first.height)) * records.size();
  detail::TiledTiffWriter writer(path, needs_big_tiff(raw), options.zip_level, options.threads);
  for (const auto& r : records) {
    const session::TiffImage frame = session::read_tiff(session_folder / r.file);
    if (frame.width != first.width || frame.height != first.height || frame.samples_per_pixel != 1 ||
        frame.bits_per_sample != 8 * format.bytes_per_sample)
      throw std::invalid_argument(fmt::format("frames OME-TIFF: {}: {}x{} pixels of {}x{} bits, the journal says {}x{} {}",
                                              r.file, frame.width, frame.height, frame.samples_per_pixel,
                                              frame.bits_per_sample, r.width, r.height, format.name));
    writer.add_page(frame.data.data(), frame.width, frame.height,
                    format.bytes_per_sample == 1 ? detail::SampleType::kUint8 : detail::SampleType::kUint16, xml);
  }
  writer.finish();
}

}  // namespace chromo::maps
