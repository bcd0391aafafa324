#pragma once
// The virtual lab's cameras as its configuration lists them: one entry per
// camera (name, address, sensor, pixel format, pose, spectral sensitivity),
// read from the JSON list that chromod's `virtual_lab.cameras` and
// chromo-sim's `--cameras FILE` share (docs/config.md "The built-in virtual
// lab"), and turned into CameraSimulatorOptions.
//
// An entry's keys (all but name optional):
//   name           device name, [A-Za-z0-9_+.-]{1,64}, unique in the list
//   serial         GigE Vision serial, 1-15 characters (default: the lab's)
//   address        "auto" (default: a free one in 127.77.0.0/16) or 127.a.b.c, unique
//   sensor_width   16-4096 pixels (default 640)
//   sensor_height  16-4096 pixels (default 480)
//   pixel_format   Mono8 ... RGB8 (drivers::kPixelFormats; default BayerRG12)
//   pose           {distance_mm, azimuth_deg, elevation_deg, roll_deg,
//                   focal_length_mm, pixel_size_um}: the camera looks at the
//                   patch centre from there (camera_view.hpp); absent: the
//                   patch fills the sensor square-on
//   sensitivity    "builtin:NAME" or a CSV wavelength_nm,R,G,B (default: the lab's)
//
// read_lab_cameras checks every key's JSON type and range and throws
// std::invalid_argument "[i].key: what is wrong" (the caller prefixes the
// list's own name); a sensitivity file is only read by
// lab_camera_sensitivity. Pure functions; no state.

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/drivers/camera.hpp"
#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/spectral/camera.hpp"

namespace chromo::simulators {

struct LabCameraPose {
  double distance_mm = 300;      // eye to the patch centre
  double azimuth_deg = 0;        // swung towards +X (right), |.| < 90
  double elevation_deg = 0;      // swung towards −Y (up), |.| < 90
  double roll_deg = 0;           // about the optical axis
  double focal_length_mm = 8;
  double pixel_size_um = 3.45;
};

struct LabCamera {
  std::string name = "cam0";
  std::string serial;            // "" = the lab's default serial for this camera
  std::string address;           // "" = a free one in 127.77.0.0/16
  int sensor_width = 640;
  int sensor_height = 480;
  drivers::PixelFormat pixel_format = drivers::PixelFormat::kBayerRG12;
  std::optional<LabCameraPose> pose;
  std::string sensitivity;       // "" = the lab's; "builtin:NAME" or a CSV path
};

// The JSON list (array of objects) as LabCameras; at least one camera.
std::vector<LabCamera> read_lab_cameras(const nlohmann::json& list);

// Camera `index`'s serial: its entry's, else `first_serial` for camera 0
// and the first 13 characters of it followed by the index for the others
// (15 characters at most for up to 64 cameras).
std::string lab_camera_serial(const LabCamera& camera, const std::string& first_serial, std::size_t index);

// The camera's view of a patch (none without a pose): intrinsics from its
// sensor and lens, looking at the patch centre from its orbit.
std::optional<CameraView> lab_camera_view(const LabCamera& camera);

// The subject's width one image row spans, in mm, at the scale of the image
// centre (the geometry the maps' scale bar needs, docs/maps.md "Scale bar"):
// without a pose the patch fills the sensor, so `patch_width_mm`; with one,
// the sensor's width times the patch millimetres one sensor pixel covers
// along its row at the image centre (the homography's local scale there:
// distance × pixel size / focal length for a square-on camera). Throws as
// patch_to_image_homography for a patch not in front of the camera.
double lab_camera_field_width_mm(const LabCamera& camera, double patch_width_mm);

// The sensitivity it names, or `fallback` when it names none. Throws
// spectral::DataError (or std::invalid_argument for an unknown builtin).
spectral::CameraSensitivity lab_camera_sensitivity(const LabCamera& camera,
                                                   const spectral::CameraSensitivity& fallback);

// Camera `index` of a lab as its simulator's options: its serial
// (lab_camera_serial), address, sensor, pixel format and view of a patch
// `patch_width_mm` wide, `sensitivity` (lab_camera_sensitivity, resolved by
// the caller), and its own noise: camera k draws from `seed` + k. The one
// conversion chromod's built-in lab and chromo-sim share.
CameraSimulatorOptions lab_camera_simulator_options(const LabCamera& camera, std::size_t index,
                                                    const std::string& first_serial, double patch_width_mm,
                                                    std::uint64_t seed, const spectral::CameraSensitivity& sensitivity);

// The analyser of camera `camera` on a polarised sphere whose pattern is
// designed for the view along the patch normal (docs/polarisation.md
// "Geometry"): the default film (PolariserFilm{}), the camera's angle from
// the normal, and its view's lobe leak at `roughness_rad`
// (cross_polarisation_leak; 0 for a camera without a pose, which looks
// square-on). Throws std::invalid_argument for roughness_rad ≤ 0.
CameraAnalyser lab_camera_analyser(const LabCamera& camera, double roughness_rad);

}  // namespace chromo::simulators
