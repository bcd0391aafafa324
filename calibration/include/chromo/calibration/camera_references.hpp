#pragma once
// Camera white and dark references (issue "Calibration", item 4) and the
// conversion of frames to albedo (DESIGN.md, data flow 3):
//
//   albedo = (frame − dark) / (white − dark_white) × ρ_white
//
// per pixel and channel, where `dark` is the mean dark frame (LEDs off) at
// the frame's exposure and gain, `white` the mean frame of the white target
// under the same illumination state (the flat field: it carries the sphere's
// illumination non-uniformity, lens vignetting and pixel response), and
// `dark_white` the dark at the white capture's exposure and gain. One
// IlluminationReference per illumination state (e.g. "d65", "w57+blue").
//
// Images are cv::Mat CV_32FC(n), n = 1 (mono or raw Bayer) or 3, in DN.
// Pixels whose white signal (white − dark_white) is below min_white_signal_dn
// give NaN albedo (the white target saw no light there: nothing to divide by).
//
// Storage (docs/formats/camera-references.md): a directory beside the LED
// library (camera_reference_directory) holding camera-references.json
// (metadata) and per state three OpenEXR files of 32-bit float channels
// (R, G, B or Y): <state>-dark.exr, <state>-white.exr, <state>-dark-white.exr.
// Errors (missing file, size/channel mismatch, malformed JSON) raise
// spectral::DataError naming the file and field. A plain value type; no
// thread rules beyond cv::Mat's (copies share pixels: clone before editing).

#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace chromo::calibration {

struct IlluminationReference {
  std::string state;             // illumination state name: [a-z0-9+_.:-]+ (it names the files)
  double exposure_us = 0;        // of the frames this reference converts
  double gain_db = 0;
  double white_exposure_us = 0;  // of the white capture (may differ: the white is brighter)
  double white_reflectance = 0.99;  // ρ_white of the white target
  int frames_averaged = 0;
  cv::Mat dark, white, dark_white;  // CV_32FC(n), same size and channels
};

struct CameraReferenceSet {
  std::string camera;       // model/serial of the camera
  std::string created_utc;  // ISO 8601
  std::string led_library;  // file name of the LED library the states were solved from
  std::vector<IlluminationReference> states;
  const IlluminationReference* find(const std::string& state) const;
};

// Mean of frames (any depth, same size and channels) as CV_32F.
// std::invalid_argument for none or mismatched frames.
cv::Mat average_frames(std::span<const cv::Mat> frames);

// The albedo image (CV_32FC(n)) of a frame under the reference's state. The
// frame must match the reference's size and channels (std::invalid_argument
// naming what differs); its exposure and gain are the reference's. Scales
// for a white captured at a different exposure: × white_exposure_us / exposure_us.
cv::Mat frame_to_albedo(const cv::Mat& frame, const IlluminationReference& reference, double min_white_signal_dn = 1.0);

// <library directory>/camera-references-<UTC timestamp>/ for a set created then.
std::filesystem::path camera_reference_directory(const CameraReferenceSet& set);
void save_camera_references(const CameraReferenceSet& set, const std::filesystem::path& directory);
CameraReferenceSet load_camera_references(const std::filesystem::path& directory);

}  // namespace chromo::calibration
