#pragma once
// Small stored session folders for tests and benches: the method's standard
// plan (dark, then white and subject under D65', W57 and W57+blue) or the
// six-LED multispectral plan (each LED type alone), one frame per step and camera, written as chromod's storage writes them
// (session::SessionStore: session.json and the journal; frame TIFFs through
// write_frame_tiff) with the LED library in results/led_library.json, as
// `chromo estimate SESSION_DIR` reads them. The frames are the virtual lab's
// physics without devices: the skin scene of `seed` and the white target,
// lit by the LedLab's true emission at the mixes solved from the lab's
// measured library, read out by the camera model (BayerRG12, noise).
#include <opencv2/imgproc.hpp>

#include <filesystem>
#include <map>
#include <string>

#include "chromo/calibration/led_library_io.hpp"
#include "chromo/calibration/session_mix.hpp"
#include "chromo/session/frame_files.hpp"
#include "chromo/session/session_store.hpp"
#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/simulators/leds/led_lab.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::testing {

struct RenderedSessionFolder {
  std::string name;           // the folder's name under the root
  std::uint64_t seed = 7;     // the skin scene and the camera noise
  int scene_size = 64;        // scene pixels per side; the sensor has twice as many (binned back 2×2)
  int scene_height = 0;       // > 0: a scene_size × scene_height scene (e.g. 1224 × 1024: a 5-MP sensor)
  int cameras = 1;            // "cam0", "cam1", ...: the same scene, each its own noise
  std::string subject = "rendered forearm";
  // "standard" (one exposure: the brightest white at 85% of full scale) or
  // "multispectral" (each state's white at 85%, the dark at the longest, as
  // simulators::render_session exposes it).
  std::string plan = "standard";
};

// Writes root/<spec.name> and returns it. Throws on any failure.
inline std::filesystem::path write_rendered_session_folder(const std::filesystem::path& root,
                                                           const RenderedSessionFolder& spec) {
  namespace fs = std::filesystem;
  const int size = spec.scene_size, height = spec.scene_height > 0 ? spec.scene_height : spec.scene_size;
  simulators::SkinSceneOptions scene_options;
  scene_options.width = size;
  scene_options.height = height;
  scene_options.white_patch = false;
  scene_options.seed = spec.seed;
  scene_options.threads = 1;
  const simulators::Scene skin = simulators::make_skin_scene(scene_options);
  const simulators::Scene white = simulators::make_white_target_scene(size, height);
  simulators::LedLabOptions led_options;
  led_options.start_warm = true;
  simulators::LedLab leds(led_options);
  const calibration::LedLibrary library = simulators::lab_led_library();
  simulators::CameraModel camera{simulators::CameraModelOptions{}};

  // Each lit state's drive levels, camera weights and exposure (its
  // brightest white channel at 85% of full scale).
  session::StandardPlanOptions plan_options;
  session::SessionPlan plan = *session::builtin_plan(spec.plan, plan_options);
  std::map<std::string, drivers::DriveLevels> drive_of;
  std::map<std::string, Eigen::Matrix<double, 3, spectral::kGridSize>> weights_of;
  std::map<std::string, double> exposure_of;
  const auto& c = camera.options();
  auto key_of = [](const session::Step& step) { return session::illumination_state(step).key; };
  for (const session::Step& step : plan.steps) {
    if (step.role == session::StepRole::kDark || drive_of.count(key_of(step))) continue;
    const drivers::DriveLevels drive =
        step.illumination.kind == session::Illumination::Kind::kWeights
            ? step.illumination.weights
            : calibration::solve_session_mix(library, step.illumination.mix, "camera", false).weights;
    drive_of[key_of(step)] = drive;
    const auto w = camera.weights(leds.emit_settled(drive));
    weights_of[key_of(step)] = w;
    const Eigen::Vector3d white = w * simulators::white_target_reflectance().values().matrix();
    exposure_of[key_of(step)] =
        (0.85 * camera.max_dn() - c.black_level_dn) * c.gain_e_per_dn / (c.quantum_scale_e_per_us * white.maxCoeff());
  }
  double shortest = 1e300, longest = 0;
  for (const auto& [key, exposure] : exposure_of) shortest = std::min(shortest, exposure), longest = std::max(longest, exposure);
  for (session::Step& step : plan.steps) {
    if (spec.plan == "standard") step.exposure_us = shortest;  // one exposure, set on the brightest white
    else step.exposure_us = step.role == session::StepRole::kDark ? longest : exposure_of.at(key_of(step));
  }

  files::StorageBudget budget;
  const fs::path staging = root / (".staging-" + spec.name);
  fs::remove_all(staging);
  session::SessionStore store(staging, &budget);
  fs::path created_folder;
  {
    auto created = store.create(plan, spec.subject, nlohmann::json::array());
    created_folder = created.folder;
    std::uint64_t index = 0;
    for (std::size_t s = 0; s < plan.steps.size(); ++s) {
      const session::Step& step = plan.steps[s];
      const bool dark = step.role == session::StepRole::kDark;
      const drivers::DriveLevels drive = dark ? drivers::DriveLevels{} : drive_of.at(key_of(step));
      const auto weights = dark ? camera.weights(leds.emit_settled(drive)) : weights_of.at(key_of(step));
      const cv::Mat response = (step.role == session::StepRole::kSubject ? skin : white).render(weights);
      cv::Mat sensor;
      cv::resize(response, sensor, cv::Size(2 * size, 2 * height), 0, 0, cv::INTER_LINEAR);
      for (int c = 0; c < spec.cameras; ++c) {
        const std::uint64_t frame_index = spec.seed * 1000 + index;
        const cv::Mat dn =
            camera.expose(sensor, simulators::SensorLayout::kBayerRGGB, 0, 0, step.exposure_us, 0, frame_index);
        session::FrameRecord record;
        record.index = index;
        record.camera = "cam" + std::to_string(c);
        record.step = step.name;
        record.step_index = static_cast<int>(s);
        record.role = step.role;
        record.exposure_us = step.exposure_us;
        record.led = session::FrameLedState{.drive = drive};
        record.sequence = s;
        record.width = dn.cols;
        record.height = dn.rows;
        record.pixel_format = drivers::PixelFormat::kBayerRG12;
        char file[96];
        std::snprintf(file, sizeof file, "frames/%s/%s-%06llu.tiff", step.name.c_str(), record.camera.c_str(),
                      static_cast<unsigned long long>(s));
        record.file = file;
        fs::create_directories((created.folder / record.file).parent_path());
        const auto* bytes = dn.ptr<std::uint8_t>();
        session::write_frame_tiff(created.folder / record.file, record,
                                  {bytes, bytes + dn.total() * dn.elemSize()}, &budget);
        created.journal->append(session::to_json(record));
        ++index;
      }
      created.journal->append({{"type", "step_completed"}, {"step", step.name}, {"index", s},
                               {"frames", spec.cameras}});
    }
    created.journal->append({{"type", "state"}, {"state", "succeeded"}});
  }
  fs::create_directories(created_folder / "results");
  calibration::save_led_library(library, created_folder / "results" / "led_library.json");
  const fs::path folder = root / spec.name;
  fs::remove_all(folder);
  fs::rename(created_folder, folder);
  fs::remove_all(staging);
  return folder;
}

}  // namespace chromo::testing
