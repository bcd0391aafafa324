#include "chromo/simulators/scene/rendered_session.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "chromo/calibration/polarised_libraries.hpp"
#include "chromo/calibration/session_mix.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/simulators/polarisation/polarised_skin.hpp"
#include "chromo/simulators/polarisation/skin_surface.hpp"
#include "chromo/session/session_captures.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/files/binary_cache.hpp"
#include "chromo/files/fnv1a.hpp"
#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/simulators/leds/led_lab.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::simulators {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The frame record the daemon would store for this step's frame from "cam0".
session::FrameRecord frame_record(const session::Step& step, std::size_t index, const drivers::DriveLevels& drive,
                                  double exposure_us, const cv::Mat& dn, drivers::PixelFormat format) {
  session::FrameRecord record;
  record.index = index;
  record.step = step.name;
  record.step_index = static_cast<int>(index);
  record.role = step.role;
  record.exposure_us = exposure_us;
  if (step.role != session::StepRole::kDark) record.led = session::FrameLedState{.drive = drive};
  record.camera = "cam0";
  record.sequence = index;
  record.width = dn.cols;
  record.height = dn.rows;
  record.pixel_format = format;
  return record;
}

std::span<const std::uint8_t> bytes_of(const cv::Mat& m) {
  return {m.ptr<std::uint8_t>(), m.total() * m.elemSize()};
}

// A Bayer RGGB frame (DN) binned 2×2 as the capture builder bins it (R,
// mean of the two G, B), in units of full scale: the subject metering's view.
session::RgbImage binned_rgb(const cv::Mat& dn, double full_scale, double exposure_us) {
  session::RgbImage image;
  image.width = dn.cols / 2, image.height = dn.rows / 2, image.exposure_us = exposure_us;
  for (auto& plane : image.planes) plane.resize(image.pixels());
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * image.width + x;
      const auto at = [&](int dy, int dx) { return static_cast<double>(dn.at<std::uint16_t>(2 * y + dy, 2 * x + dx)); };
      image.planes[0][i] = static_cast<float>(at(0, 0) / full_scale);
      image.planes[1][i] = static_cast<float>(0.5 * (at(0, 1) + at(1, 0)) / full_scale);
      image.planes[2][i] = static_cast<float>(at(1, 1) / full_scale);
    }
  return image;
}

session::RgbImage flat_rgb(int width, int height, double level, double exposure_us) {
  session::RgbImage image;
  image.width = width, image.height = height, image.exposure_us = exposure_us;
  for (auto& plane : image.planes) plane.assign(image.pixels(), static_cast<float>(level));
  return image;
}

// Frame indices of the metering and linearity frames: apart from the plan's (s + 1000·f).
constexpr std::uint64_t kMeteringFrameIndex = 900000, kLinearityFrameIndex = 910000;

// ---- the on-disk cache ----
constexpr files::CacheFormat kCacheFormat{{'C', 'H', 'R', 'S', 'E', 'S', 'S', '1'}, kRenderedSessionVersion};

std::uint64_t cache_key(const RenderedSessionOptions& o, const std::vector<SceneWeights>& weights,
                        const std::map<std::string, double>& exposures, const CameraModelOptions& camera) {
  files::Fnv1a h;
  h.add(kCacheFormat.magic);
  h.add(kCacheFormat.version);
  for (int v : {o.sensor_width, o.sensor_height, o.scene_width, o.scene_height, o.window_x, o.window_y,
                o.frames_per_capture})
    h.add(v);
  h.add(o.seed), h.add(o.white_fill), h.add(o.noise_free), h.add(o.exposure_per_capture), h.add(o.blue_ratio);
  for (const auto& [step, exposure_us] : exposures) h.add(exposure_us);
  if (o.plan != "standard") h.add(o.plan.data(), o.plan.size());  // (the standard plan's keys as before)
  if (o.reference_frames > 0) h.add(o.reference_frames);          // (keys without it as before)
  if (o.linear_led_light) h.add(std::uint8_t{1});                 // (the lab's imperfections: keys
  if (o.cell_uniform_scene) h.add(std::uint8_t{2});               //  of the default lab as before)
  if (!o.scene_anomalies) h.add(std::uint8_t{3});
  if (o.subsurface.on) h.add(std::uint8_t{4}), h.add(o.subsurface.sigma_blue_px), h.add(o.subsurface.sigma_red_px);
  for (const auto& w : weights) h.add(w.data(), sizeof(double) * w.size());
  for (double v : {camera.quantum_scale_e_per_us, camera.full_well_e, camera.read_noise_e, camera.gain_e_per_dn,
                   camera.black_level_dn})
    h.add(v);
  h.add(camera.adc_bits), h.add(camera.seed);
  SkinSceneOptions probe;  // the scene generator and the skin model
  probe.width = probe.height = 16;
  probe.seed = o.seed;
  probe.white_patch = false;
  probe.threads = 1;
  const Scene scene = make_skin_scene(probe);
  h.add(scene.albedo_data(), sizeof(float) * 16 * 16 * spectral::kGridSize);
  return h.h;
}

// The payload's encoding of strings and spectra, over files::CacheWriter /
// files::CacheReader (plain values are their bytes, vectors count + elements).
void put_string(files::CacheWriter& w, const std::string& s) { w.put_vector(std::vector<char>(s.begin(), s.end())); }
void put_spectrum(files::CacheWriter& w, const spectral::Spectrum& s) {
  w.put_bytes(s.values().data(), sizeof(double) * spectral::kGridSize);
}
std::string get_string(files::CacheReader& r) {
  const auto v = r.get_vector<char>(4096);
  return {v.begin(), v.end()};
}
spectral::Spectrum get_spectrum(files::CacheReader& r) {
  spectral::Spectrum s;
  for (int i = 0; i < spectral::kGridSize; ++i) s[i] = r.get<double>();
  return s;
}

void put_measurement(files::CacheWriter& w, const session::Measurement& m) {
  put_string(w, m.set.camera.name);
  for (const auto& c : m.set.camera.rgb) put_spectrum(w, c);
  w.put<std::uint32_t>(static_cast<std::uint32_t>(m.set.channels.size()));
  for (const auto& c : m.set.channels) {
    put_string(w, c.name);
    put_spectrum(w, c.illuminant);
    w.put<std::int32_t>(c.camera_channel);
    w.put(c.noise);
  }
  w.put<std::int32_t>(m.width), w.put<std::int32_t>(m.height);
  w.put_vector(m.measured);
  w.put<std::uint32_t>(static_cast<std::uint32_t>(m.registration.size()));
  for (const auto& r : m.registration) {
    put_string(w, r.image), put_string(w, r.reference), put_string(w, r.channel);
    w.put(r.result), w.put(r.motion_px), w.put(r.warped);
  }
  w.put<std::uint64_t>(m.saturated_pixels);
  w.put<std::uint32_t>(static_cast<std::uint32_t>(m.exposures.size()));
  for (const auto& e : m.exposures) put_string(w, e.capture), w.put(e.exposure_us), w.put(e.frames);
}

session::Measurement get_measurement(files::CacheReader& r) {
  session::Measurement m;
  m.set.camera.name = get_string(r);
  for (auto& c : m.set.camera.rgb) c = get_spectrum(r);
  const auto channels = r.get<std::uint32_t>();
  if (channels > 4096) throw std::runtime_error("bad channel count");
  for (std::uint32_t k = 0; k < channels; ++k) {
    estimation::MeasurementChannel c;
    c.name = get_string(r);
    c.illuminant = get_spectrum(r);
    c.camera_channel = r.get<std::int32_t>();
    c.noise = r.get<estimation::ChannelNoise>();
    m.set.channels.push_back(std::move(c));
  }
  m.width = r.get<std::int32_t>(), m.height = r.get<std::int32_t>();
  m.measured = r.get_vector<float>(std::uint64_t{1} << 32);
  const auto reports = r.get<std::uint32_t>();
  if (reports > 4096) throw std::runtime_error("bad registration count");
  for (std::uint32_t k = 0; k < reports; ++k) {
    session::RegistrationReport report;
    report.image = get_string(r), report.reference = get_string(r), report.channel = get_string(r);
    report.result = r.get<session::RegistrationResult>();
    report.motion_px = r.get<double>();
    report.warped = r.get<bool>();
    m.registration.push_back(std::move(report));
  }
  m.saturated_pixels = r.get<std::uint64_t>();
  const auto exposures = r.get<std::uint32_t>();
  if (exposures > 4096) throw std::runtime_error("bad exposure count");
  for (std::uint32_t k = 0; k < exposures; ++k) {
    session::Measurement::CaptureExposure e;
    e.capture = get_string(r);
    e.exposure_us = r.get<double>();
    e.frames = r.get<std::uint32_t>();
    m.exposures.push_back(std::move(e));
  }
  return m;
}

std::filesystem::path cache_file(const std::filesystem::path& dir, std::uint64_t key) {
  return dir / files::cache_file_name("rendered_session", key);
}

// Fills out's rendered parts from the cache file; false when absent, damaged or of other inputs.
bool load_cached(const std::filesystem::path& file, std::uint64_t key, RenderedSession& out) {
  const auto payload = files::read_cache(file, kCacheFormat, key);
  if (!payload) return false;
  try {
    files::CacheReader r(*payload);
    RenderedSession s;
    s.width = r.get<std::int32_t>(), s.height = r.get<std::int32_t>();
    s.scene_seconds = r.get<double>(), s.camera_seconds = r.get<double>(), s.measurement_seconds = r.get<double>();
    s.noisy = get_measurement(r);
    if (r.get<bool>()) s.noise_free = get_measurement(r);
    s.truth = r.get_vector<estimation::SkinParameters>(std::uint64_t{1} << 28);
    s.region = r.get_vector<std::uint8_t>(std::uint64_t{1} << 28);
    const std::size_t pixels = static_cast<std::size_t>(s.width) * s.height;
    if (!r.at_end() || s.truth.size() != pixels || s.region.size() != pixels ||
        s.noisy.measured.size() != pixels * s.noisy.set.channels.size())
      return false;
    out.width = s.width, out.height = s.height;
    out.scene_seconds = s.scene_seconds, out.camera_seconds = s.camera_seconds, out.measurement_seconds = s.measurement_seconds;
    out.noisy = std::move(s.noisy), out.noise_free = std::move(s.noise_free);
    out.truth = std::move(s.truth), out.region = std::move(s.region);
    out.loaded_from_cache = true;
    return true;
  } catch (const std::exception&) {
    return false;  // a count out of range (get_measurement)
  }
}

void store_cached(const std::filesystem::path& file, std::uint64_t key, const RenderedSession& s) {
  files::CacheWriter w;
  w.put<std::int32_t>(s.width), w.put<std::int32_t>(s.height);
  w.put(s.scene_seconds), w.put(s.camera_seconds), w.put(s.measurement_seconds);
  put_measurement(w, s.noisy);
  w.put(!s.noise_free.measured.empty());
  if (!s.noise_free.measured.empty()) put_measurement(w, s.noise_free);
  w.put_vector(s.truth);
  w.put_vector(s.region);
  try {
    files::write_cache(file, kCacheFormat, key, w.take_bytes());
  } catch (const std::exception&) {
    // A cache that cannot be written is not an error: the session is in memory.
  }
}

// The registration's error against the true motion, on the measurement grid
// (sensor coordinates s = 2m + 0.5 of a 2×2 cell's centre).
// moved_states: the states whose subject captures were registered, in the
// measurement's report order (every state after the plan's first).
std::vector<CaptureMotion> capture_motion(const session::Measurement& m,
                                          const std::map<std::string, std::pair<double, SubjectPose>>& poses,
                                          const std::vector<std::string>& moved_states, int sensor_width,
                                          int sensor_height) {
  std::vector<CaptureMotion> out;
  for (std::size_t k = 0; k < m.registration.size() && k < moved_states.size(); ++k) {
    const auto& [t, pose] = poses.at(moved_states[k]);
    const cv::Matx23d truth = pose_matrix(pose, 0.5 * (sensor_width - 1), 0.5 * (sensor_height - 1));
    const session::RegistrationResult& found = m.registration[k].result;
    CaptureMotion c;
    c.capture = moved_states[k] == "w57" ? "W57" : moved_states[k] == "w57+blue" ? "W57+blue" : moved_states[k];
    c.seconds_since_reference = t;
    c.pose = pose;
    c.found_motion_px = m.registration[k].motion_px;
    double sum = 0;
    int count = 0;
    for (int gy = 0; gy < 9; ++gy)
      for (int gx = 0; gx < 9; ++gx) {
        const double mx = (m.width - 1) * gx / 8.0, my = (m.height - 1) * gy / 8.0;
        // The found transform applies only when the capture was warped.
        const bool warped = m.registration[k].warped;
        const double fx = warped ? found.warp[0][0] * mx + found.warp[0][1] * my + found.warp[0][2] : mx;
        const double fy = warped ? found.warp[1][0] * mx + found.warp[1][1] * my + found.warp[1][2] : my;
        const cv::Vec3d sensor(2 * mx + 0.5, 2 * my + 0.5, 1.0);
        const cv::Vec2d moved = truth * sensor;
        const double tx = (moved[0] - 0.5) / 2, ty = (moved[1] - 0.5) / 2;
        const double e = std::hypot(fx - tx, fy - ty);
        c.registration_error_max_px = std::max(c.registration_error_max_px, e);
        sum += e * e, ++count;
      }
    c.registration_error_rms_px = std::sqrt(sum / count);
    out.push_back(c);
  }
  return out;
}

// σ of the surface map (parallel − cross)/2, green, in albedo units, from
// the camera model: per sensor site the subject's electrons e = a·W/ρ and the
// white's W (W: the white's green electrons at this exposure), variances
// e + r² and W + r² (r: read noise), two green sites per 2×2 cell; albedo
// a = ρ·(s − d)/(w − d) → σ²(a) = (ρ/W)²·(e + r² + (a/ρ)²·(W + r²))/2. The
// parallel capture sees a + 2·F more (its sheen); the two captures are
// independent. a: the mean green albedo of the skin model at the scene's
// mean parameters (scene.hpp), seen through both films by these weights.
double surface_map_sigma(const CameraModel& camera, double exposure_us, double white_green_response,
                         const SceneWeights& weights, const spectral::Spectrum& films) {
  const CameraModelOptions& c = camera.options();
  const spectral::Spectrum skin = estimation::SkinModel().albedo({0.05, 0.025, 0.7, 0.006});
  const double filtered_green = (weights.row(1).array() * films.values().transpose()).sum();
  const double a = (weights.row(1).array() * (films.values() * skin.values()).transpose()).sum() / filtered_green;
  const double rho = kWhiteTargetReflectance;
  const double white_e = c.quantum_scale_e_per_us * exposure_us * white_green_response;
  const double read2 = c.read_noise_e * c.read_noise_e;
  auto variance = [&](double albedo) {
    const double e = albedo / rho * white_e;
    return (rho / white_e) * (rho / white_e) * (e + read2 + (albedo / rho) * (albedo / rho) * (white_e + read2)) / 2;
  };
  const double sheen = fresnel_reflectance_unpolarised(kSkinRefractiveIndex, 0.0);
  return std::sqrt(variance(a) + variance(a + 2 * sheen)) / 2;
}

// The light the capture builder assumes for these drive levels: each LED
// type's library spectrum per unit drive times its drive.
spectral::Spectrum linear_light(const calibration::LedLibrary& library, const drivers::DriveLevels& drive) {
  spectral::Spectrum light;
  for (auto type : spectral::kAllLedTypes)
    light += library.led(type).spectrum_per_unit_drive() * drive[static_cast<std::size_t>(spectral::led_type_index(type))];
  return light;
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
  if (!motion.IsValid(error)) return false;
  if (settle_ms > 60000) return fail("settle_ms: must be 0-60000");
  if (!(readout_ms >= 0 && readout_ms <= 10000)) return fail("readout_ms: must be 0-10000");
  if (!session::builtin_plan(plan)) return fail("plan: must be a built-in plan (standard, multispectral, multispectral+method)");
  if (!(blue_ratio >= 0 && blue_ratio <= 100)) return fail("blue_ratio: must be in [0, 100] (0: the plain w57+blue mix)");
  if (frames_per_capture < 1 || frames_per_capture > 64) return fail("frames_per_capture: must be in [1, 64]");
  if (polarised && plan != "standard") return fail("polarised: only the standard plan is rendered polarised");
  if (!(extinction_ratio_550nm >= 1 && extinction_ratio_550nm <= 100000))
    return fail("extinction_ratio_550nm: must be in [1, 100000]");
  if (oily.count < 0 || oily.count > 64) return fail("oily.count: must be 0-64");
  if (oily.count > 0 && !polarised) return fail("oily: oily regions are rendered on a polarised session only");
  if (reference_frames < 0 || reference_frames > 64) return fail("reference_frames: must be in [0, 64] (0: frames_per_capture)");
  if (cell_uniform_scene && (scene_w % 2 || scene_h % 2 || window_x % 2 || window_y % 2 || scene_w < 32 || scene_h < 32))
    return fail("cell_uniform_scene: the scene's size and the window's position must be even, the scene at least 32 per side");
  if (!scene_anomalies && polarised) return fail("scene_anomalies: false only on an unpolarised session");
  if (std::string spread_error; subsurface.on && !subsurface.IsValid(&spread_error)) return fail(spread_error.c_str());
  if (linear_led_light && polarised) return fail("linear_led_light: only on an unpolarised session");
  if (!(subject_fill == 0 || (subject_fill > 0.05 && subject_fill < 0.99)))
    return fail("subject_fill: must be 0 (off) or in (0.05, 0.99)");
  if (subject_fill > 0 && !(exposure_per_capture && plan == "standard"))
    return fail("subject_fill: needs exposure_per_capture and the standard plan");
  if (!(subject_percentile > 0 && subject_percentile <= 1)) return fail("subject_percentile: must be in (0, 1]");
  if (!(max_subject_exposure_ratio >= 1 && max_subject_exposure_ratio <= session::kMaxSubjectExposureRatio))
    return fail("max_subject_exposure_ratio: must be in [1, 64]");
  if (!(camera_nonlinearity >= 0 && camera_nonlinearity <= 0.5)) return fail("camera_nonlinearity: must be in [0, 0.5]");
  return true;
}

calibration::LedLibrary lab_led_library() {
  LedLab leds([] {
    LedLabOptions o;
    o.start_warm = true;
    return o;
  }());
  calibration::LedLibrary library = calibration::nominal_led_library();
  library.source = "measured";
  for (std::size_t t = 0; t < spectral::kLedTypeCount; ++t) {
    drivers::DriveLevels drive{};
    drive[t] = 1.0;
    library.leds[t].ladder = {{1.0, std::nullopt, std::nullopt, true, leds.emit_settled(drive)}};
  }
  return library;
}

namespace {

// RenderedSessionOptions::subject_fill: each subject step's exposure from a
// first (metering) frame of it at its white's exposure; W57 takes W57+blue's.
void meter_subjects(const RenderedSessionOptions& options, const CameraModel& camera, const SkinSceneResponse& scene,
                    const std::map<std::string, int>& state_of_step, session::SessionPlan& plan, RenderedSession& out) {
  const double full_scale = camera.max_dn();
  const session::SubjectMetering metering{options.subject_fill, options.subject_percentile,
                                          options.max_subject_exposure_ratio};
  const cv::Size sensor(options.sensor_width, options.sensor_height);
  const double dark_level = camera.options().black_level_dn / full_scale;
  std::map<std::string, double> ratio_of_step;
  for (std::size_t s = 0; s < plan.steps.size(); ++s) {
    const session::Step& step = plan.steps[s];
    if (step.role != session::StepRole::kSubject || step.name == "subject_w57") continue;
    const cv::Mat dn = camera.expose(scene.responses[state_of_step.at(step.name)], SensorLayout::kBayerRGGB, 0, 0,
                                     step.exposure_us, 0, kMeteringFrameIndex + s);
    const session::RgbImage frame = binned_rgb(dn, full_scale, step.exposure_us);
    const session::SubjectMeteringResult r = session::meter_subject_exposure(
        frame, flat_rgb(frame.width, frame.height, dark_level, 0), metering);
    out.subject_metering[step.name] = r;
    ratio_of_step[step.name] = r.exposure_ratio;
  }
  if (ratio_of_step.count("subject_w57+blue")) {
    ratio_of_step["subject_w57"] = ratio_of_step["subject_w57+blue"];
    out.subject_metering["subject_w57"] = out.subject_metering["subject_w57+blue"];
  }
  for (session::Step& step : plan.steps) {
    auto found = ratio_of_step.find(step.name);
    if (found == ratio_of_step.end()) continue;
    step.exposure_us *= found->second;
    out.exposure_us_of_step[step.name] = step.exposure_us;
  }
}

// Each scaled white's linearity check: the white at t_white / g (one noisy frame).
void add_linearity_whites(const CameraModel& camera, const std::vector<cv::Vec3f>& white_response,
                          const std::map<std::string, int>& state_of_step, const session::SessionPlan& plan,
                          session::Captures& standard) {
  const char* const white_steps[] = {"white_d65", "white_w57", "white_w57+blue"};  // the captures' order
  for (std::size_t k = 0; k < std::size(white_steps); ++k) {
    session::IlluminatedCapture* capture = &standard.captures.at(k);
    const double t_white = capture->white.exposure_us, t_subject = capture->subject.exposure_us;
    if (!(t_white > 0) || std::abs(t_subject - t_white) <= 1e-6 * t_white) continue;
    const std::string white_step = white_steps[k];
    const std::size_t s = static_cast<std::size_t>(
        std::find_if(plan.steps.begin(), plan.steps.end(), [&](const session::Step& x) { return x.name == white_step; }) -
        plan.steps.begin());
    const double t_check = t_white * t_white / t_subject;
    const cv::Mat response(2 * capture->white.height, 2 * capture->white.width, CV_32FC3,
                           white_response[state_of_step.at(white_step)]);
    const cv::Mat dn = camera.expose(response, SensorLayout::kBayerRGGB, 0, 0, t_check, 0, kLinearityFrameIndex + s);
    capture->white_linearity = binned_rgb(dn, camera.max_dn(), t_check);
  }
}

}  // namespace

RenderedSession render_session(const RenderedSessionOptions& options) {
  if (std::string error; !options.IsValid(&error)) throw std::invalid_argument("RenderedSessionOptions: " + error);
  RenderedSession out;
  auto start = Clock::now();

  // Light: the library a perfect calibration measures, the calibrated mixes, their true emission.
  LedLab leds([] {
    LedLabOptions o;
    o.start_warm = true;
    return o;
  }());
  out.library = lab_led_library();
  const CameraModel camera{[&] {
    CameraModelOptions o;
    o.nonlinearity_at_full_well = options.camera_nonlinearity;
    return o;
  }()};
  const CameraModelOptions& c = camera.options();
  std::optional<PolarisedSphere> sphere;
  spectral::Spectrum films = spectral::Spectrum::constant(1.0);  // T_P·T_A (1: no films)
  if (options.polarised) {
    PolarisedSphere s;
    s.light_film.extinction_ratio_550nm = options.extinction_ratio_550nm;
    s.light_film.extinction_ratio_400nm = std::min(s.light_film.extinction_ratio_400nm, options.extinction_ratio_550nm);
    s.analyser_film = s.light_film;
    sphere = s;
    films = diffuse_transmission(s.light_film, s.analyser_film);
    out.library = calibration::library_through_polariser(out.library, films);
    out.sheen = fresnel_reflectance_unpolarised(kSkinRefractiveIndex, 0.0);
  }

  // The plan the daemon would run. The standard plan as chromod builds it
  // (exposure per capture: its whites metered, `w57+blue:R`); another
  // built-in plan as listed (each capture exposed for its own white).
  const bool standard = options.plan == "standard";
  session::StandardPlanOptions plan_options;
  plan_options.frames_per_camera = static_cast<std::uint32_t>(options.frames_per_capture);
  plan_options.reference_frames = static_cast<std::uint32_t>(options.reference_frames);
  session::SessionPlan plan;
  if (standard) {
    plan_options.blue_ratio = options.blue_ratio;
    if (options.exposure_per_capture) plan_options.meter_white_share = options.white_fill;
    plan_options.subject_fill = options.subject_fill;
    plan_options.subject_percentile = options.subject_percentile;
    plan_options.max_subject_exposure_ratio = options.max_subject_exposure_ratio;
    plan_options.polarised = options.polarised;
    plan = session::standard_plan(plan_options);
  } else {
    plan = *session::builtin_plan(options.plan, plan_options);
  }
  for (session::Step& step : plan.steps) step.settle_ms = options.settle_ms;

  // The plan's illumination states (one per subject step, in plan order,
  // paired with their whites by session::illumination_state): a mix solved
  // as a calibrated daemon would (named without its ":R"), or the step's own
  // weights.
  std::vector<std::string> state_names, state_keys;
  std::vector<drivers::Polarisation> state_polarisation;
  std::map<std::string, int> state_of_step;  // subject and white steps → state index
  for (const session::Step& step : plan.steps) {
    if (step.role != session::StepRole::kSubject) continue;
    const session::IlluminationState state = session::illumination_state(step);
    state_polarisation.push_back(step.polarisation);
    if (step.illumination.kind == session::Illumination::Kind::kMix)
      out.mixes[state.name] = calibration::solve_session_mix(out.library, step.illumination.mix, "camera", false).weights;
    else
      out.mixes[state.name] = step.illumination.weights;
    state_names.push_back(state.name);
    state_keys.push_back(state.key);
  }
  for (const session::Step& step : plan.steps) {
    if (step.role == session::StepRole::kDark) continue;
    const std::string key = session::illumination_state(step).key;
    state_of_step[step.name] = static_cast<int>(std::find(state_keys.begin(), state_keys.end(), key) - state_keys.begin());
  }
  std::vector<SceneWeights> weights;
  std::vector<cv::Vec3f> white_response;
  std::vector<double> brightest_of_state;
  double brightest = 0;
  for (const std::string& name : state_names) {
    const auto w = camera.weights(options.linear_led_light ? linear_light(out.library, out.mixes[name])
                                                           : leds.emit_settled(out.mixes[name]));
    weights.emplace_back(w);
    const Eigen::Vector3d white = w * (white_target_reflectance().values() * films.values()).matrix();
    white_response.emplace_back(static_cast<float>(white[0]), static_cast<float>(white[1]), static_cast<float>(white[2]));
    out.white_response[name] = {white[0], white[1], white[2]};
    brightest_of_state.push_back(white.maxCoeff());
    brightest = std::max(brightest, white.maxCoeff());
  }
  auto exposure_for = [&](double brightest_response) {
    return (options.white_fill * camera.max_dn() - c.black_level_dn) * c.gain_e_per_dn /
           (c.quantum_scale_e_per_us * brightest_response);
  };
  // Each step's exposure. The standard plan: one exposure for every step
  // (its brightest white at white_fill), or with exposure per capture each
  // metered white at white_fill and the steps that take an earlier white's
  // exposure at that. Other plans: each state its own exposure, the dark at
  // the longest.
  out.exposure_us = exposure_for(brightest);
  double dark_exposure_us = out.exposure_us;
  if (!standard)
    for (double b : brightest_of_state) dark_exposure_us = std::max(dark_exposure_us, exposure_for(b));
  for (session::Step& step : plan.steps) {
    double exposure = out.exposure_us;
    if (step.role == session::StepRole::kDark) exposure = dark_exposure_us;
    else if (!standard) exposure = exposure_for(brightest_of_state[state_of_step.at(step.name)]);
    else if (step.meter_white_share > 0) exposure = exposure_for(brightest_of_state[state_of_step.at(step.name)]);
    else if (!step.exposure_from.empty()) exposure = out.exposure_us_of_step.at(step.exposure_from);
    out.exposure_us_of_step[step.name] = exposure;
    step.exposure_us = exposure;
  }
  std::filesystem::path cached;
  std::uint64_t key = 0;
  if (options.polarised) out.surface_sigma = surface_map_sigma(camera, out.exposure_us_of_step.at("subject_d65"),
                                                                white_response[state_of_step.at("subject_d65")][1],
                                                                weights[state_of_step.at("subject_d65")], films);
  if (!options.cache_dir.empty() && !options.motion.enabled && !options.polarised && options.subject_fill == 0 &&
      options.camera_nonlinearity == 0) {
    key = cache_key(options, weights, out.exposure_us_of_step, c);
    cached = cache_file(options.cache_dir, key);
    if (load_cached(cached, key, out)) return out;
  }

  // Scene at the sensor's resolution, in bands.
  SkinSceneOptions scene_options;
  const int cell = options.cell_uniform_scene ? 2 : 1;  // sensor sites per scene pixel, per side
  scene_options.width = (options.scene_width > 0 ? options.scene_width : options.sensor_width) / cell;
  scene_options.height = (options.scene_height > 0 ? options.scene_height : options.sensor_height) / cell;
  scene_options.column_begin = options.window_x / cell, scene_options.column_count = options.sensor_width / cell;
  scene_options.row_begin = options.window_y / cell, scene_options.row_count = options.sensor_height / cell;
  scene_options.anomalies = options.scene_anomalies;
  scene_options.seed = options.seed;
  scene_options.white_patch = false;
  scene_options.threads = options.threads;
  scene_options.oily = options.oily;
  scene_options.oily.sigma_reflectance = out.surface_sigma;
  scene_options.subsurface = options.subsurface;
  SkinSceneResponse scene =
      render_polarised_skin_scene(scene_options, weights, state_polarisation, sphere, options.band_rows);
  if (options.cell_uniform_scene) {  // each scene pixel onto its 2×2 sensor cell
    for (cv::Mat& r : scene.responses) cv::resize(r, r, cv::Size(), 2, 2, cv::INTER_NEAREST);
    for (cv::Mat* m : {&scene.regions, &scene.cm, &scene.ch, &scene.bm, &scene.che})
      cv::resize(*m, *m, cv::Size(), 2, 2, cv::INTER_NEAREST);
  }
  out.scene_seconds = seconds_since(start);
  if (options.subject_fill > 0) meter_subjects(options, camera, scene, state_of_step, plan, out);

  // The plan's timeline: each subject step's exposure mid-point, relative
  // to the first subject step's, and the subject's pose then (per state).
  std::vector<double> exposure_mid_s(plan.steps.size());
  double clock_s = 0, reference_s = -1;
  for (std::size_t s = 0; s < plan.steps.size(); ++s) {
    const session::Step& step = plan.steps[s];
    const double frames = step.frames_per_camera;
    exposure_mid_s[s] = clock_s + step.settle_ms / 1000.0 + frames * step.exposure_us / 2e6;
    if (step.role == session::StepRole::kSubject && reference_s < 0) reference_s = exposure_mid_s[s];
    clock_s += step.settle_ms / 1000.0 + frames * (step.exposure_us / 1e6 + options.readout_ms / 1000.0);
  }
  out.plan_seconds = clock_s;
  std::map<std::string, std::pair<double, SubjectPose>> poses;  // per state: time since the reference, pose
  {
    int subject_index = 0;
    for (std::size_t s = 0; s < plan.steps.size(); ++s)
      if (plan.steps[s].role == session::StepRole::kSubject) {
        const double t = exposure_mid_s[s] - reference_s;
        poses[state_names[state_of_step.at(plan.steps[s].name)]] = {t, subject_pose(options.motion, t, subject_index++)};
      }
  }

  // Frames of the plan through the daemon's capture builder.
  const session::CaptureSources sources{out.library, "true LED emission at full drive (rendered session)",
                               c.sensitivity, "builtin:nikon_d5100", kWhiteTargetReflectance};
  const cv::Size sensor(options.sensor_width, options.sensor_height);
  auto captures = [&](bool noisy) {
    session::SessionCaptureBuilder builder(plan, sources);
    for (std::size_t s = 0; s < plan.steps.size(); ++s) {
      const session::Step& step = plan.steps[s];
      const double exposure_us = step.exposure_us;
      cv::Mat response;
      drivers::DriveLevels drive{};
      if (step.role == session::StepRole::kDark) {
        response = cv::Mat(sensor, CV_32FC3, cv::Scalar::all(0));
      } else {
        const int k = state_of_step.at(step.name);
        drive = out.mixes.at(state_names[k]);
        if (step.role == session::StepRole::kWhite) response = cv::Mat(sensor, CV_32FC3, white_response[k]);
        else response = move_subject(scene.responses[k], poses.at(state_names[k]).second);
      }
      for (std::uint32_t f = 0; f < step.frames_per_camera; ++f) {
        // Frame f of step s: its own noise (the first frame's as before frames per capture).
        const std::uint64_t frame_index = s + 1000 * static_cast<std::uint64_t>(f);
        if (noisy) {
          const cv::Mat dn = camera.expose(response, SensorLayout::kBayerRGGB, 0, 0, exposure_us, 0, frame_index);
          builder.add_frame(frame_record(step, s, drive, exposure_us, dn, drivers::PixelFormat::kBayerRG12), bytes_of(dn));
        } else {
          cv::Mat dn16;  // the 16-bit encoding: DN << 4, here with the fraction kept to 1/16 DN
          camera.expected(response, SensorLayout::kBayerRGGB, 0, 0, exposure_us, 0).convertTo(dn16, CV_16U, 16.0);
          builder.add_frame(frame_record(step, s, drive, exposure_us, dn16, drivers::PixelFormat::kBayerRG16),
                            bytes_of(dn16));
        }
      }
    }
    return builder;
  };
  auto measurement = [&](const session::SessionCaptureBuilder& builder) {
    session::Captures captures = builder.captures();
    if (!standard) return session::build_measurement(captures);
    if (sphere && options.estimator_knows_films)
      captures.surface_factors = session::SurfaceFactors{
          surface_factor_in_albedo(drivers::Polarisation::kCross, sphere->light_film, sphere->analyser_film, sphere->cross_leak),
          surface_factor_in_albedo(drivers::Polarisation::kParallel, sphere->light_film, sphere->analyser_film, sphere->cross_leak),
          "the rendered session's films (PolariserFilm, 1:" + std::to_string(options.extinction_ratio_550nm) +
              " at 550 nm, design view)"};
    if (options.subject_fill > 0) add_linearity_whites(camera, white_response, state_of_step, plan, captures);
    return session::build_measurement(captures);
  };
  start = Clock::now();
  session::SessionCaptureBuilder noisy_captures = captures(true);
  std::optional<session::SessionCaptureBuilder> clean_captures;
  if (options.noise_free) clean_captures.emplace(captures(false));
  out.camera_seconds = seconds_since(start);
  start = Clock::now();
  out.noisy = measurement(noisy_captures);
  if (options.noise_free) {
    out.noise_free = measurement(*clean_captures);
    for (std::size_t k = 0; k < out.noise_free.set.channels.size(); ++k)
      out.noise_free.set.channels[k].noise = out.noisy.set.channels[k].noise;
  }
  out.measurement_seconds = seconds_since(start);
  if (options.keep_captures) out.noisy_captures = std::make_shared<const session::SessionCaptureBuilder>(std::move(noisy_captures));
  out.motion = capture_motion(out.noisy, poses, std::vector<std::string>(state_names.begin() + 1, state_names.end()),
                              options.sensor_width, options.sensor_height);

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
  if (!cached.empty()) store_cached(cached, key, out);
  return out;
}

std::vector<float> cell_added_reflection(const RenderedSessionOptions& options, double surface_sigma) {
  const int scene_w = options.scene_width > 0 ? options.scene_width : options.sensor_width;
  const int scene_h = options.scene_height > 0 ? options.scene_height : options.sensor_height;
  SkinSceneOptions scene;
  scene.width = scene_w, scene.height = scene_h, scene.seed = options.seed;
  scene.oily = options.oily;
  scene.oily.sigma_reflectance = surface_sigma;
  if (scene.oily.count > 0 && !(surface_sigma > 0))
    throw std::invalid_argument("cell_added_reflection: oily regions need the session's surface_sigma > 0");
  const int cells_x = options.sensor_width / 2, cells_y = options.sensor_height / 2;
  std::vector<float> reflection(static_cast<std::size_t>(cells_x) * cells_y);
  for (int cy = 0; cy < cells_y; ++cy)
    for (int cx = 0; cx < cells_x; ++cx) {
      double sum = 0;
      for (int d = 0; d < 4; ++d)
        sum += skin_scene_added_reflection(scene_w, scene_h, options.window_x + 2 * cx + d % 2,
                                                       options.window_y + 2 * cy + d / 2) +
               skin_scene_oily_reflection(scene, options.window_x + 2 * cx + d % 2, options.window_y + 2 * cy + d / 2);
      reflection[static_cast<std::size_t>(cy) * cells_x + cx] = static_cast<float>(sum / 4);
    }
  return reflection;
}

}  // namespace chromo::simulators
