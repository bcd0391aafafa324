#include "chromo/calibration/camera_references.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/files/bounded_read.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>

#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "chromo/calibration/led_library_io.hpp"
#include "chromo/files/durable_file.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {
namespace {

using spectral::DataError;

const char* channel_name(int channels, int c) {
  if (channels == 1) return "Y";
  static const char* kRgb[] = {"R", "G", "B"};
  return kRgb[c];
}

// Durably: the JSON written last names only images that are on disk.
void write_exr(const cv::Mat& image, const std::filesystem::path& path) {
  files::commit_file_durably(path, nullptr, [&](const std::filesystem::path& temporary) {
    const int channels = image.channels();
    cv::Mat continuous = image.isContinuous() ? image : image.clone();
    Imf::Header header(continuous.cols, continuous.rows);
    for (int c = 0; c < channels; ++c) header.channels().insert(channel_name(channels, c), Imf::Channel(Imf::FLOAT));
    Imf::OutputFile file(temporary.c_str(), header);
    Imf::FrameBuffer frame;
    char* base = reinterpret_cast<char*>(continuous.ptr<float>());
    for (int c = 0; c < channels; ++c)
      frame.insert(channel_name(channels, c), Imf::Slice(Imf::FLOAT, base + c * sizeof(float), sizeof(float) * channels,
                                                         sizeof(float) * channels * continuous.cols));
    file.setFrameBuffer(frame);
    file.writePixels(continuous.rows);
  });
}

cv::Mat read_exr(const std::filesystem::path& path, int channels) {
  try {
    files::check_exr_file(path);  // a regular file, its data window within the image cap, before OpenEXR opens it
    Imf::InputFile file(path.c_str());
    const auto window = file.header().dataWindow();
    const int width = window.max.x - window.min.x + 1, height = window.max.y - window.min.y + 1;
    for (int c = 0; c < channels; ++c)
      if (!file.header().channels().findChannel(channel_name(channels, c)))
        throw DataError(fmt::format("{}: no channel '{}' (expected {} channel(s))", path.string(), channel_name(channels, c), channels));
    cv::Mat image(height, width, CV_32FC(channels));
    Imf::FrameBuffer frame;
    char* base = reinterpret_cast<char*>(image.ptr<float>()) -
                 (static_cast<std::ptrdiff_t>(window.min.x) + static_cast<std::ptrdiff_t>(window.min.y) * width) * channels * sizeof(float);
    for (int c = 0; c < channels; ++c)
      frame.insert(channel_name(channels, c), Imf::Slice(Imf::FLOAT, base + c * sizeof(float), sizeof(float) * channels,
                                                         sizeof(float) * channels * width));
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    return image;
  } catch (const DataError&) {
    throw;
  } catch (const std::exception& e) {
    throw DataError(path.string() + ": " + e.what());
  }
}

void check_state_name(const std::string& state) {
  if (state.empty()) throw DataError("camera references: empty illumination state name");
  for (char c : state)
    if (!(std::islower(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) ||
          std::string_view("+_.:-").find(c) != std::string_view::npos))
      throw DataError("camera references: state name '" + state + "' may only hold [a-z0-9+_.:-]");
}

}  // namespace

const IlluminationReference* CameraReferenceSet::find(const std::string& state) const {
  for (const auto& s : states)
    if (s.state == state) return &s;
  return nullptr;
}

cv::Mat average_frames(std::span<const cv::Mat> frames) {
  if (frames.empty()) throw std::invalid_argument("average_frames: no frames");
  cv::Mat sum = cv::Mat::zeros(frames[0].size(), CV_64FC(frames[0].channels()));
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].size() != frames[0].size() || frames[i].channels() != frames[0].channels())
      throw std::invalid_argument(fmt::format("average_frames: frame {} is {}x{}x{}, frame 0 {}x{}x{}", i, frames[i].cols,
                                              frames[i].rows, frames[i].channels(), frames[0].cols, frames[0].rows,
                                              frames[0].channels()));
    cv::Mat f;
    frames[i].convertTo(f, CV_64F);
    sum += f;
  }
  cv::Mat mean;
  sum.convertTo(mean, CV_32F, 1.0 / frames.size());
  return mean;
}

cv::Mat frame_to_albedo(const cv::Mat& frame, const IlluminationReference& r, double min_white_signal_dn) {
  auto same = [&](const cv::Mat& m, const char* what) {
    if (m.size() != frame.size() || m.channels() != frame.channels())
      throw std::invalid_argument(fmt::format("frame_to_albedo: frame is {}x{}x{} but the '{}' {} is {}x{}x{}", frame.cols,
                                              frame.rows, frame.channels(), r.state, what, m.cols, m.rows, m.channels()));
  };
  same(r.dark, "dark");
  same(r.white, "white");
  same(r.dark_white, "dark_white");
  if (!(r.exposure_us > 0) || !(r.white_exposure_us > 0))
    throw std::invalid_argument("frame_to_albedo: reference '" + r.state + "' has no exposure");
  cv::Mat f;
  frame.convertTo(f, CV_32F);
  cv::Mat signal = f - r.dark;
  cv::Mat white_signal = r.white - r.dark_white;
  const float scale = static_cast<float>(r.white_reflectance * r.white_exposure_us / r.exposure_us);
  cv::Mat albedo(frame.size(), CV_32FC(frame.channels()));
  const int n = frame.rows * frame.cols * frame.channels();
  const float* s = signal.ptr<float>();
  const float* w = white_signal.ptr<float>();
  float* a = albedo.ptr<float>();
  for (int i = 0; i < n; ++i)
    a[i] = w[i] >= min_white_signal_dn ? s[i] / w[i] * scale : std::numeric_limits<float>::quiet_NaN();
  return albedo;
}

std::filesystem::path camera_reference_directory(const CameraReferenceSet& set) {
  std::string stamp;
  for (char c : set.created_utc)
    if (std::isalnum(static_cast<unsigned char>(c))) stamp += c;
  return led_library_directory() / ("camera-references-" + stamp);
}

void save_camera_references(const CameraReferenceSet& set, const std::filesystem::path& directory) {
  nlohmann::json meta;
  meta["format"] = "chromosphere-camera-references";
  meta["version"] = 1;
  meta["camera"] = set.camera;
  meta["created_utc"] = set.created_utc;
  meta["led_library"] = set.led_library;
  meta["states"] = nlohmann::json::array();
  for (const auto& s : set.states) {
    check_state_name(s.state);
    if (s.dark.empty() || s.white.empty() || s.dark_white.empty() || s.dark.type() != CV_32FC(s.dark.channels()) ||
        s.white.type() != s.dark.type() || s.dark_white.type() != s.dark.type() || s.white.size() != s.dark.size() ||
        s.dark_white.size() != s.dark.size() || (s.dark.channels() != 1 && s.dark.channels() != 3))
      throw DataError("camera references: state '" + s.state + "': dark, white and dark_white must be float images of one size with 1 or 3 channels");
    meta["states"].push_back({{"state", s.state},
                              {"exposure_us", s.exposure_us},
                              {"gain_db", s.gain_db},
                              {"white_exposure_us", s.white_exposure_us},
                              {"white_reflectance", s.white_reflectance},
                              {"frames_averaged", s.frames_averaged},
                              {"width", s.dark.cols},
                              {"height", s.dark.rows},
                              {"channels", s.dark.channels()},
                              {"dark", s.state + "-dark.exr"},
                              {"white", s.state + "-white.exr"},
                              {"dark_white", s.state + "-dark-white.exr"}});
  }
  std::filesystem::create_directories(directory);
  for (const auto& s : set.states) {
    write_exr(s.dark, directory / (s.state + "-dark.exr"));
    write_exr(s.white, directory / (s.state + "-white.exr"));
    write_exr(s.dark_white, directory / (s.state + "-dark-white.exr"));
  }
  // Metadata last, durably: a set with its JSON is complete.
  try {
    files::write_file_durably(directory / "camera-references.json", meta.dump(2) + "\n", nullptr);
  } catch (const std::exception& e) {
    throw DataError((directory / "camera-references.json").string() + ": cannot write (" + e.what() + ")");
  }
}

CameraReferenceSet load_camera_references(const std::filesystem::path& directory) {
  const auto path = directory / "camera-references.json";
  nlohmann::json meta;
  try {
    meta = nlohmann::json::parse(files::read_text_file(path, "JSON"));
  } catch (const std::exception& e) {
    throw DataError(path.string() + ": " + e.what());
  }
  auto field = [&](const nlohmann::json& object, const std::string& name, const std::string& where) -> const nlohmann::json& {
    if (!object.is_object() || !object.contains(name)) throw DataError(path.string() + ": " + where + name + ": missing");
    return object.at(name);
  };
  try {
    if (field(meta, "format", "") != "chromosphere-camera-references")
      throw DataError(path.string() + ": format: not chromosphere-camera-references");
    if (field(meta, "version", "") != 1) throw DataError(path.string() + ": version: only 1 is known");
    CameraReferenceSet set;
    set.camera = field(meta, "camera", "").get<std::string>();
    set.created_utc = field(meta, "created_utc", "").get<std::string>();
    set.led_library = field(meta, "led_library", "").get<std::string>();
    const auto& states = field(meta, "states", "");
    for (std::size_t i = 0; i < states.size(); ++i) {
      const std::string where = fmt::format("states[{}].", i);
      const auto& j = states[i];
      IlluminationReference r;
      r.state = field(j, "state", where).get<std::string>();
      check_state_name(r.state);
      r.exposure_us = field(j, "exposure_us", where).get<double>();
      r.gain_db = field(j, "gain_db", where).get<double>();
      r.white_exposure_us = field(j, "white_exposure_us", where).get<double>();
      r.white_reflectance = field(j, "white_reflectance", where).get<double>();
      r.frames_averaged = field(j, "frames_averaged", where).get<int>();
      const int channels = field(j, "channels", where).get<int>();
      const int width = field(j, "width", where).get<int>(), height = field(j, "height", where).get<int>();
      if (channels != 1 && channels != 3) throw DataError(path.string() + ": " + where + "channels: must be 1 or 3");
      if (!(r.white_reflectance > 0 && r.white_reflectance <= 1))
        throw DataError(path.string() + ": " + where + "white_reflectance: must be in (0, 1]");
      for (auto [name, mat] : {std::pair{"dark", &r.dark}, {"white", &r.white}, {"dark_white", &r.dark_white}}) {
        const auto file = directory / field(j, name, where).get<std::string>();
        *mat = read_exr(file, channels);
        if (mat->cols != width || mat->rows != height)
          throw DataError(fmt::format("{}: {}x{}, but {}{} says {}x{}", file.string(), mat->cols, mat->rows, where, name, width, height));
      }
      set.states.push_back(std::move(r));
    }
    return set;
  } catch (const nlohmann::json::exception& e) {
    throw DataError(path.string() + ": " + e.what());
  }
}

}  // namespace chromo::calibration
