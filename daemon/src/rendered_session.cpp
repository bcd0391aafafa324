#include "chromo/daemon/rendered_session.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "chromo/daemon/calibrations.hpp"
#include "chromo/daemon/session_captures.hpp"
#include "chromo/daemon/session_plan.hpp"
#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/simulators/leds/led_lab.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::daemon {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The LedLab's true emission at `drive`, junctions settled at that drive.
spectral::Spectrum emit(simulators::LedLab& leds, const drivers::DriveLevels& drive) {
  drivers::LedState state;
  state.drive = drive;
  leds.apply(state);
  leds.set_output_enabled(true);
  leds.settle_thermal();
  return leds.irradiance_now();
}

nlohmann::json led_record(const drivers::DriveLevels& drive) {
  nlohmann::json levels = nlohmann::json::object();
  for (std::size_t t = 0; t < spectral::kLedTypeCount; ++t)
    levels[std::string(spectral::led_type_name(spectral::kAllLedTypes[t]))] = drive[t];
  return {{"drive", levels}};
}

std::span<const std::uint8_t> bytes_of(const cv::Mat& m) {
  return {m.ptr<std::uint8_t>(), m.total() * m.elemSize()};
}

}  // namespace

bool RenderedSessionOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (sensor_width < 16 || sensor_width > 4096 || sensor_width % 2) return fail("sensor_width: must be even, 16-4096");
  if (sensor_height < 16 || sensor_height > 4096 || sensor_height % 2) return fail("sensor_height: must be even, 16-4096");
  const int scene_w = scene_width > 0 ? scene_width : sensor_width, scene_h = scene_height > 0 ? scene_height : sensor_height;
  if (scene_w > 4096 || scene_h > 4096 || window_x < 0 || window_y < 0 || window_x + sensor_width > scene_w ||
      window_y + sensor_height > scene_h)
    return fail("window_x/window_y: the sensor's window must lie within the scene (at most 4096 per side)");
  if (!(white_fill > 0.05 && white_fill < 0.99)) return fail("white_fill: must be in (0.05, 0.99)");
  if (threads < 1) return fail("threads: must be >= 1");
  if (band_rows < 1) return fail("band_rows: must be >= 1");
  return true;
}

RenderedSession render_session(const RenderedSessionOptions& options) {
  if (std::string error; !options.IsValid(&error)) throw std::invalid_argument("RenderedSessionOptions: " + error);
  RenderedSession out;
  auto start = Clock::now();

  // Light: the library a perfect calibration measures, the calibrated mixes, their true emission.
  simulators::LedLab leds([] {
    simulators::LedLabOptions o;
    o.start_warm = true;
    return o;
  }());
  out.library = calibration::nominal_led_library();
  out.library.source = "measured";
  for (std::size_t t = 0; t < spectral::kLedTypeCount; ++t) {
    drivers::DriveLevels drive{};
    drive[t] = 1.0;
    out.library.leds[t].ladder = {{1.0, std::nullopt, std::nullopt, true, emit(leds, drive)}};
  }
  const char* const kMixes[3] = {"d65", "w57", "w57+blue"};
  const simulators::CameraModel camera{simulators::CameraModelOptions{}};
  std::vector<simulators::SceneWeights> weights;
  std::map<std::string, cv::Vec3f> white_response;
  double brightest = 0;
  for (const char* mix : kMixes) {
    out.mixes[mix] = solve_session_mix(out.library, mix, "camera", false).weights;
    const auto w = camera.weights(emit(leds, out.mixes[mix]));
    weights.emplace_back(w);
    const Eigen::Vector3d white = w * simulators::white_target_reflectance().values().matrix();
    white_response[mix] = cv::Vec3f(static_cast<float>(white[0]), static_cast<float>(white[1]), static_cast<float>(white[2]));
    brightest = std::max(brightest, white.maxCoeff());
  }
  const simulators::CameraModelOptions& c = camera.options();
  out.exposure_us = (options.white_fill * camera.max_dn() - c.black_level_dn) * c.gain_e_per_dn /
                    (c.quantum_scale_e_per_us * brightest);

  // Scene at the sensor's resolution, in bands.
  simulators::SkinSceneOptions scene_options;
  scene_options.width = options.scene_width > 0 ? options.scene_width : options.sensor_width;
  scene_options.height = options.scene_height > 0 ? options.scene_height : options.sensor_height;
  scene_options.column_begin = options.window_x, scene_options.column_count = options.sensor_width;
  scene_options.row_begin = options.window_y, scene_options.row_count = options.sensor_height;
  scene_options.seed = options.seed;
  scene_options.white_patch = false;
  scene_options.threads = options.threads;
  const simulators::SkinSceneResponse scene = simulators::render_skin_scene(scene_options, weights, options.band_rows);
  out.scene_seconds = seconds_since(start);

  // Frames of the standard plan through the daemon's capture builder.
  StandardPlanOptions plan_options;
  plan_options.exposure_us = out.exposure_us;
  const SessionPlan plan = standard_plan(plan_options);
  const CaptureSources sources{out.library, "true LED emission at full drive (rendered session)",
                               c.sensitivity, "builtin:nikon_d5100", simulators::kWhiteTargetReflectance};
  const cv::Size sensor(options.sensor_width, options.sensor_height);
  auto captures = [&](bool noisy) {
    SessionCaptureBuilder builder(plan, sources);
    for (std::size_t s = 0; s < plan.steps.size(); ++s) {
      const Step& step = plan.steps[s];
      cv::Mat response;
      drivers::DriveLevels drive{};
      if (step.role == StepRole::kDark) {
        response = cv::Mat(sensor, CV_32FC3, cv::Scalar::all(0));
      } else {
        drive = out.mixes.at(step.illumination.mix);
        const int k = static_cast<int>(std::find(std::begin(kMixes), std::end(kMixes), step.illumination.mix) - kMixes);
        if (step.role == StepRole::kWhite) response = cv::Mat(sensor, CV_32FC3, white_response.at(step.illumination.mix));
        else response = scene.responses[k];
      }
      const nlohmann::json led = step.role == StepRole::kDark ? nlohmann::json::object() : led_record(drive);
      if (noisy) {
        const cv::Mat dn = camera.expose(response, simulators::SensorLayout::kBayerRGGB, 0, 0, out.exposure_us, 0, s);
        builder.add_frame(step.name, "cam0", "BayerRG12", dn.cols, dn.rows, bytes_of(dn), led);
      } else {
        cv::Mat dn16;  // the 16-bit encoding: DN << 4, here with the fraction kept to 1/16 DN
        camera.expected(response, simulators::SensorLayout::kBayerRGGB, 0, 0, out.exposure_us, 0)
            .convertTo(dn16, CV_16U, 16.0);
        builder.add_frame(step.name, "cam0", "BayerRG16", dn16.cols, dn16.rows, bytes_of(dn16), led);
      }
    }
    return builder.captures();
  };
  start = Clock::now();
  const estimation::MethodCaptures noisy_captures = captures(true);
  estimation::MethodCaptures clean_captures;
  if (options.noise_free) clean_captures = captures(false);
  out.camera_seconds = seconds_since(start);
  start = Clock::now();
  out.noisy = estimation::build_method_measurement(noisy_captures);
  if (options.noise_free) {
    out.noise_free = estimation::build_method_measurement(clean_captures);
    for (std::size_t k = 0; k < out.noise_free.set.channels.size(); ++k)
      out.noise_free.set.channels[k].noise = out.noisy.set.channels[k].noise;
  }
  out.measurement_seconds = seconds_since(start);

  // Truth per 2×2 cell.
  out.width = options.sensor_width / 2, out.height = options.sensor_height / 2;
  out.truth.resize(static_cast<std::size_t>(out.width) * out.height);
  out.region.resize(out.truth.size());
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * out.width + x;
      estimation::SkinParameters& p = out.truth[i];
      p = {0, 0, 0, 0};
      const std::uint8_t first = scene.regions.at<std::uint8_t>(2 * y, 2 * x);
      out.region[i] = first;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int sy = 2 * y + dy, sx = 2 * x + dx;
          p.cm += 0.25 * scene.cm.at<float>(sy, sx);
          p.ch += 0.25 * scene.ch.at<float>(sy, sx);
          p.bm += 0.25 * scene.bm.at<float>(sy, sx);
          p.che += 0.25 * scene.che.at<float>(sy, sx);
          if (scene.regions.at<std::uint8_t>(sy, sx) != first) out.region[i] = kMixedCell;
        }
    }
  return out;
}

}  // namespace chromo::daemon
