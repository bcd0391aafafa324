#include "chromo/calibration/camera_chart.hpp"

#include <Eigen/QR>
#include <algorithm>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {

const ColourChart& ohta_colour_checker() {
  static const ColourChart chart = [] {
    const spectral::Table table = spectral::parse_table(spectral::data::embedded_file("colorchecker_reflectance_ohta.csv"),
                                                        "data/colorchecker_reflectance_ohta.csv");
    ColourChart c;
    c.name = "ColorChecker Classic (Ohta 1997)";
    for (std::size_t i = 1; i < table.column_names.size(); ++i) {
      c.patch_names.push_back(table.column_names[i]);
      c.reflectance.push_back(spectral::resample_column(table, table.column_names[i]));
    }
    return c;
  }();
  return chart;
}

Eigen::MatrixXd camera_chart_rows(const spectral::CameraSensitivity& camera, const ColourChart& chart,
                                  const spectral::Spectrum& target) {
  const auto patches = static_cast<Eigen::Index>(chart.reflectance.size());
  Eigen::MatrixXd rows(3 * patches, spectral::kGridSize);
  for (int c = 0; c < 3; ++c) {
    const double white = (camera.rgb[c].values() * target.values()).sum();
    if (!(white > 0.0))
      throw spectral::DataError("camera '" + camera.name + "' channel " + "RGB"[c] + " sees nothing of the target");
    for (Eigen::Index p = 0; p < patches; ++p)
      rows.row(3 * p + c) = (camera.rgb[c].values() * chart.reflectance[p].values() / white).matrix().transpose();
  }
  return rows;
}

ChartDeltaE camera_chart_delta_e00(const spectral::CameraSensitivity& camera, const ColourChart& chart,
                                   const spectral::Spectrum& target, const spectral::Spectrum& mix) {
  const auto patches = static_cast<Eigen::Index>(chart.reflectance.size());
  // Each light white-normalised by its own white, as the capture pipeline
  // computes albedo (frame / white reference under the same light).
  const Eigen::VectorXd rgb_target = camera_chart_rows(camera, chart, target) * target.values().matrix();
  const Eigen::VectorXd rgb_mix = camera_chart_rows(camera, chart, mix) * mix.values().matrix();
  Eigen::MatrixXd rgb(patches, 3), xyz(patches, 3);
  for (Eigen::Index p = 0; p < patches; ++p) {
    rgb.row(p) = rgb_target.segment<3>(3 * p).transpose();
    const spectral::Xyz v = spectral::xyz_of_reflectance(chart.reflectance[p], target);
    xyz.row(p) << v.X, v.Y, v.Z;
  }
  const Eigen::Matrix3d to_xyz = rgb.colPivHouseholderQr().solve(xyz);  // xyz ≈ rgb · to_xyz
  const spectral::Xyz white = spectral::white_point(target);
  ChartDeltaE result;
  for (Eigen::Index p = 0; p < patches; ++p) {
    const Eigen::RowVector3d t = rgb_target.segment<3>(3 * p).transpose() * to_xyz;
    const Eigen::RowVector3d m = rgb_mix.segment<3>(3 * p).transpose() * to_xyz;
    const double de = spectral::delta_e00(spectral::lab_from_xyz({t[0], t[1], t[2]}, white),
                                          spectral::lab_from_xyz({m[0], m[1], m[2]}, white));
    result.delta_e00.push_back(de);
    result.mean += de / static_cast<double>(patches);
    result.max = std::max(result.max, de);
  }
  return result;
}

}  // namespace chromo::calibration
