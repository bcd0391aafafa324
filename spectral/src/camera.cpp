#include "chromo/spectral/camera.hpp"

#include <string>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::spectral {

CameraSensitivity builtin_camera(std::string_view name) {
  static const Table table = parse_table(data::embedded_file("camera_sensitivity.csv"), "data/camera_sensitivity.csv");
  const std::string prefix(name);
  for (const auto& column : table.column_names) {
    if (column == prefix + "_R") {
      return {prefix,
              {resample_column(table, prefix + "_R"), resample_column(table, prefix + "_G"),
               resample_column(table, prefix + "_B")}};
    }
  }
  throw DataError("unknown built-in camera '" + prefix +
                  "' (built in: nikon_d5100, canon_eos_5d_mark_ii, sony_ilce_7m3)");
}

CameraSensitivity read_camera_sensitivity(const std::filesystem::path& path) {
  Table table = read_table(path);
  return {path.stem().string(),
          {resample_column(table, "R"), resample_column(table, "G"), resample_column(table, "B")}};
}

CameraWeights camera_weights(const CameraSensitivity& camera, const Spectrum& illuminant) {
  CameraWeights w;
  for (int c = 0; c < 3; ++c) {
    const GridArray product = camera.rgb[c].values() * illuminant.values();
    const double white = product.sum();
    if (!(white > 0.0))
      throw DataError("camera '" + camera.name + "' channel " + "RGB"[c] + " sees nothing under this illuminant");
    w.row(c) = (product / white).matrix().transpose();
  }
  return w;
}

Eigen::Vector3d camera_response(const CameraSensitivity& camera, const Spectrum& illuminant, const Spectrum& albedo) {
  return camera_weights(camera, illuminant) * albedo.values().matrix();
}

}  // namespace chromo::spectral
