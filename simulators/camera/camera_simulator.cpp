// CameraSimulator: see camera_simulator.hpp; the transport is the project's
// GigeVisionDevice, the registers are camera_registers.hpp.
#include "chromo/simulators/camera/camera_simulator.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "camera_registers.hpp"
#include "chromo/simulators/polarisation/polarised_skin.hpp"
#include "gige_protocol.hpp"

namespace chromo::simulators {
namespace {

namespace reg = camera_registers;
using Clock = std::chrono::steady_clock;

SensorLayout layout_of(drivers::ColourLayout layout) {
  switch (layout) {
    case drivers::ColourLayout::kBayerRGGB: return SensorLayout::kBayerRGGB;
    case drivers::ColourLayout::kRgb: return SensorLayout::kThreeChannel;
    case drivers::ColourLayout::kMono: return SensorLayout::kMono;
  }
  return SensorLayout::kMono;
}

bool same_light(const spectral::Spectrum& a, const spectral::Spectrum& b) { return (a.values() == b.values()).all(); }

bool same_split(const std::optional<PolarisedIrradiance>& a, const std::optional<PolarisedIrradiance>& b) {
  if (a.has_value() != b.has_value()) return false;
  return !a || (same_light(a->unpolarised, b->unpolarised) && same_light(a->cross, b->cross) &&
                same_light(a->parallel, b->parallel));
}

bool any_light(const spectral::Spectrum& light) { return (light.values() != 0).any(); }

}  // namespace

bool CameraAnalyser::IsValid(std::string* error) const {
  if (!film.IsValid(error)) return false;
  if (!(view_angle_deg >= 0 && view_angle_deg < 90)) {
    if (error != nullptr) *error = "analyser: view_angle_deg must be in [0, 90)";
    return false;
  }
  if (!(cross_leak >= 0 && cross_leak <= 1)) {
    if (error != nullptr) *error = "analyser: cross_leak must be in [0, 1]";
    return false;
  }
  return true;
}

bool CameraSimulatorOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (serial.empty() || serial.size() > 15) return fail("serial must be 1-15 characters (GigE Vision bootstrap)");
  if (sensor_width < 16 || sensor_height < 16 || sensor_width > 4096 || sensor_height > 4096)
    return fail("sensor size must be 16-4096 pixels");
  GigeVisionDeviceOptions device;
  device.address = address;
  device.serial = serial;
  device.genicam_xml.assign(1, '-');  // checked by the constructor; any text passes here
  device.faults = faults;
  device.first_block_id = first_block_id;
  if (!device.IsValid(error)) return false;
  if (!(patch_width_mm > 0 && patch_width_mm <= 10000)) return fail("patch_width_mm must be in (0, 10000]");
  if (view) {
    if (view->intrinsics.width_px != sensor_width || view->intrinsics.height_px != sensor_height)
      return fail("view: the intrinsics' size must be the sensor's");
    std::string view_error;
    if (!view->IsValid(&view_error)) return fail("view: " + view_error);
  }
  if (analyser && !analyser->IsValid(error)) return false;
  return camera_model.IsValid(error);
}

bool TriggerFaultOptions::IsValid(std::string* error) const {
  if (!(ignore_probability >= 0 && ignore_probability <= 0.5)) {
    if (error != nullptr) *error = "ignore_probability must be in [0, 0.5]";
    return false;
  }
  for (std::uint64_t number : ignore_triggers)
    if (number == 0) {
      if (error != nullptr) *error = "ignore_triggers: trigger numbers start at 1";
      return false;
    }
  return true;
}

CameraSimulator::CameraSimulator(CameraSimulatorOptions options, std::shared_ptr<const SphereIllumination> illumination,
                                 std::shared_ptr<const Scene> scene)
    : options_(std::move(options)),
      model_(options_.camera_model),
      illumination_(std::move(illumination)),
      scene_(std::move(scene)) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("CameraSimulatorOptions: " + error);
  if (!illumination_ || !scene_) throw std::invalid_argument("CameraSimulator: illumination and scene are required");
  check_view(*scene_);
  GigeVisionDeviceOptions device;
  device.address = options_.address;
  device.serial = options_.serial;
  device.model = "CHROMO-SIM-CAM";
  device.genicam_xml = reg::genicam_xml(device.model);
  device.camera_register_base = reg::kBase;
  device.camera_register_count = reg::kCount;
  device.faults = options_.faults;
  device.first_block_id = options_.first_block_id;
  device_ = std::make_unique<GigeVisionDevice>(std::move(device));
  device_->set_write_hook([this](std::uint32_t address, std::uint32_t value,
                                 const GigeVisionDevice::RegisterReader& read) {
    return on_register_write(address, value, read);
  });
  device_->set_on_control_lost([this] {
    std::lock_guard lock(acquisition_mutex_);
    acquiring_ = false;
    acquisition_cv_.notify_all();
  });
  power_on();
}

CameraSimulator::~CameraSimulator() { power_off(); }

void CameraSimulator::apply_power_on_registers() {
  device_->set_camera_register(reg::kSensorWidth, options_.sensor_width);
  device_->set_camera_register(reg::kSensorHeight, options_.sensor_height);
  device_->set_camera_register(reg::kWidth, std::min(512, options_.sensor_width));
  device_->set_camera_register(reg::kHeight, std::min(512, options_.sensor_height));
  device_->set_camera_register(reg::kOffsetX, 0);
  device_->set_camera_register(reg::kOffsetY, 0);
  device_->set_camera_register(reg::kPixelFormat, drivers::pixel_format_info(options_.pixel_format).pfnc_code);
  device_->set_camera_register(reg::kAcquisitionMode, reg::kModeContinuous);
  device_->set_camera_register(reg::kFramePeriodUs, 100000);
  device_->set_camera_register(reg::kExposureUs, 10000);
  device_->set_camera_register(reg::kGainCentiDb, 0);
  device_->set_camera_register(reg::kTriggerMode, 0);
  device_->set_camera_register(reg::kTriggerSource, reg::kSourceSoftware);
  device_->set_camera_register(reg::kTriggerActivation, 0);
  device_->set_camera_register(reg::kAcquisitionActive, 0);
  device_->set_camera_register(reg::kChunkModeActive, 0);
  device_->set_camera_register(reg::kChunkSelector, 0);
  device_->set_camera_register(reg::kChunkEnable, 0);
  std::lock_guard lock(acquisition_mutex_);
  acquiring_ = single_frame_ = trigger_on_ = false;
  trigger_source_ = reg::kSourceSoftware;
  frame_period_us_ = 100000;
  pending_triggers_.clear();
  trigger_count_ = 0;
}

// Validates a controller's write and mirrors the acquisition state. Runs on
// the device's GVCP thread under its lock: registers only through `read`.
std::uint16_t CameraSimulator::on_register_write(std::uint32_t address, std::uint32_t value,
                                                 const GigeVisionDevice::RegisterReader& read) {
  using namespace gige;
  std::lock_guard lock(acquisition_mutex_);
  const bool image_format = address == reg::kWidth || address == reg::kHeight || address == reg::kOffsetX ||
                            address == reg::kOffsetY || address == reg::kPixelFormat ||
                            address == reg::kChunkModeActive || address == reg::kChunkEnable;  // the payload's size
  if (image_format && acquiring_) return kStatusBusy;  // the transport layer's parameters are locked
  const std::uint32_t sensor_width = read(reg::kSensorWidth), sensor_height = read(reg::kSensorHeight);
  switch (address) {
    case reg::kSensorWidth:
    case reg::kSensorHeight:
    case reg::kAcquisitionActive: return kStatusWriteProtect;
    case reg::kWidth: return value >= 1 && value + read(reg::kOffsetX) <= sensor_width ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kHeight:
      return value >= 1 && value + read(reg::kOffsetY) <= sensor_height ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kOffsetX: return value + read(reg::kWidth) <= sensor_width ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kOffsetY: return value + read(reg::kHeight) <= sensor_height ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kPixelFormat: return drivers::pixel_format_from_pfnc(value) ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kAcquisitionMode:
      return value == reg::kModeContinuous || value == reg::kModeSingleFrame ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kFramePeriodUs:
      if (value < 1000 || value > 10000000) return kStatusInvalidParameter;
      frame_period_us_ = value;
      break;
    case reg::kExposureUs: return value >= 10 && value <= 10000000 ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kGainCentiDb: return value <= 2400 ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kTriggerMode:
      if (value > 1) return kStatusInvalidParameter;
      trigger_on_ = value == 1;
      pending_triggers_.clear();
      break;
    case reg::kTriggerSource:
      if (value != reg::kSourceLine0 && value != reg::kSourceSoftware) return kStatusInvalidParameter;
      trigger_source_ = value;
      break;
    case reg::kTriggerActivation: return value == 0 ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kAcquisitionStart:
      acquiring_ = true;
      single_frame_ = read(reg::kAcquisitionMode) == reg::kModeSingleFrame;
      pending_triggers_.clear();
      trigger_count_ = 0;
      break;
    case reg::kAcquisitionStop:
      acquiring_ = false;
      pending_triggers_.clear();
      break;
    case reg::kTriggerSoftware:
      if (acquiring_ && trigger_on_ && trigger_source_ == reg::kSourceSoftware) accept_trigger_locked();
      break;
    case reg::kChunkModeActive:
    case reg::kChunkEnable: return value <= 1 ? kStatusSuccess : kStatusInvalidParameter;
    case reg::kChunkSelector: return value == 0 ? kStatusSuccess : kStatusInvalidParameter;
    default: return kStatusInvalidAddress;  // inside the block but not a register
  }
  acquisition_cv_.notify_all();
  return kStatusSuccess;
}

void CameraSimulator::start_acquisition_thread() {
  {
    std::lock_guard lock(acquisition_mutex_);
    quit_ = false;
  }
  frame_index_ = 0;
  acquisition_thread_ = std::thread([this] { acquisition_loop(); });
}

void CameraSimulator::stop_acquisition_thread() {
  {
    std::lock_guard lock(acquisition_mutex_);
    quit_ = true;
  }
  acquisition_cv_.notify_all();
  if (acquisition_thread_.joinable()) acquisition_thread_.join();
}

void CameraSimulator::acquisition_loop() {
  std::unique_lock lock(acquisition_mutex_);
  auto next_frame = Clock::now();
  bool was_acquiring = false;
  while (!quit_) {
    if (!acquiring_) {
      if (was_acquiring) {
        lock.unlock();
        device_->set_camera_register(reg::kAcquisitionActive, 0);
        lock.lock();
        was_acquiring = false;
      }
      acquisition_cv_.wait(lock, [this] { return quit_ || acquiring_; });
      next_frame = Clock::now();
      continue;
    }
    if (!was_acquiring) {
      lock.unlock();
      device_->set_camera_register(reg::kAcquisitionActive, 1);
      lock.lock();
      was_acquiring = true;
      continue;  // the state may have changed meanwhile
    }
    std::uint64_t trigger_count = 0;  // free-running frames answer no trigger
    if (trigger_on_) {
      if (pending_triggers_.empty()) {
        acquisition_cv_.wait(lock, [this] { return quit_ || !acquiring_ || !trigger_on_ || !pending_triggers_.empty(); });
        continue;
      }
      trigger_count = pending_triggers_.front();
      pending_triggers_.pop_front();
    } else {
      if (acquisition_cv_.wait_until(lock, next_frame, [this] { return quit_ || !acquiring_ || trigger_on_; }))
        continue;
      const auto period = std::chrono::microseconds(frame_period_us_);
      next_frame += period;
      if (next_frame < Clock::now() - period) next_frame = Clock::now();  // no burst after a stall
    }
    lock.unlock();
    produce_frame(trigger_count);
    lock.lock();
    if (single_frame_) acquiring_ = false;
  }
}

void CameraSimulator::accept_trigger_locked() {
  ++trigger_count_;
  const std::uint64_t number = ++triggers_received_;
  const bool listed = std::find(trigger_faults_.ignore_triggers.begin(), trigger_faults_.ignore_triggers.end(),
                                number) != trigger_faults_.ignore_triggers.end();
  const bool rolled = trigger_faults_.ignore_probability > 0 &&
                      std::uniform_real_distribution<double>(0, 1)(trigger_dice_) < trigger_faults_.ignore_probability;
  if (listed || rolled) {
    ++triggers_ignored_;
    return;
  }
  pending_triggers_.push_back(trigger_count_);
  acquisition_cv_.notify_all();
}

void CameraSimulator::set_trigger_faults(const TriggerFaultOptions& faults) {
  std::string error;
  if (!faults.IsValid(&error)) throw std::invalid_argument("TriggerFaultOptions: " + error);
  std::lock_guard lock(acquisition_mutex_);
  trigger_faults_ = faults;
  trigger_dice_.seed(faults.seed);
}

namespace {

// The block's payload: the image alone, or (chunk mode with TriggerCount
// enabled) the image chunk and the TriggerCount chunk (camera_registers.hpp).
void append_chunks(std::vector<std::uint8_t>& payload, std::uint64_t trigger_count) {
  const auto image_bytes = static_cast<std::uint32_t>(payload.size());
  auto put32 = [&](std::uint32_t v) {
    for (int i = 0; i < 4; ++i) payload.push_back(static_cast<std::uint8_t>(v >> (24 - 8 * i)));
  };
  put32(reg::kImageChunkId);
  put32(image_bytes);
  for (int i = 0; i < 8; ++i) payload.push_back(static_cast<std::uint8_t>(trigger_count >> (56 - 8 * i)));
  put32(reg::kTriggerCountChunkId);
  put32(reg::kTriggerCountChunkBytes);
}

}  // namespace

void CameraSimulator::produce_frame(std::uint64_t trigger_count) {
  const int width = static_cast<int>(device_->camera_register(reg::kWidth));
  const int height = static_cast<int>(device_->camera_register(reg::kHeight));
  const int offset_x = static_cast<int>(device_->camera_register(reg::kOffsetX));
  const int offset_y = static_cast<int>(device_->camera_register(reg::kOffsetY));
  const std::uint32_t pfnc = device_->camera_register(reg::kPixelFormat);
  const double exposure_us = device_->camera_register(reg::kExposureUs);
  const double gain_db = device_->camera_register(reg::kGainCentiDb) / 100.0;
  const auto known = drivers::pixel_format_from_pfnc(pfnc);
  if (!known) return;  // the write hook admits only the table's formats
  const drivers::PixelFormatInfo& format = drivers::pixel_format_info(*known);

  std::function<void()> hook;
  {
    std::lock_guard lock(render_mutex_);
    hook = exposure_hook_;
  }
  const std::uint64_t timestamp = device_->now_ticks();
  if (hook) hook();  // the LED controller's trigger input sees the exposure start
  GvspImageBlock block;
  block.pixel_format = pfnc;
  block.width = width;
  block.height = height;
  block.offset_x = offset_x;
  block.offset_y = offset_y;
  block.timestamp_ticks = timestamp;
  const bool chunks = device_->camera_register(reg::kChunkModeActive) == 1 &&
                      device_->camera_register(reg::kChunkEnable) == 1;
  block.has_chunks = chunks;
  if (options_.test_pattern) {
    auto pattern = std::make_shared<std::vector<std::uint8_t>>(format.frame_bytes(width, height));
    const std::size_t row_bytes = pattern->size() / static_cast<std::size_t>(height);
    const auto frame = static_cast<std::uint8_t>(frame_index_++);
    for (int y = 0; y < height; ++y)
      for (std::size_t x = 0; x < row_bytes; ++x)
        (*pattern)[static_cast<std::size_t>(y) * row_bytes + x] = static_cast<std::uint8_t>(x + y + frame);
    ++frames_rendered_;
    if (chunks) append_chunks(*pattern, trigger_count);
    block.payload = std::move(pattern);
    device_->send_block(block);
    return;
  }
  const spectral::Spectrum irradiance = illumination_->irradiance_now();
  const std::optional<PolarisedIrradiance> split =
      options_.analyser ? illumination_->polarised_irradiance_now() : std::nullopt;
  cv::Mat response;
  {
    std::lock_guard lock(render_mutex_);
    if (cached_response_.empty() || cached_scene_ != scene_ || !same_light(cached_irradiance_, irradiance) ||
        !same_split(cached_split_, split)) {
      cached_response_ = to_sensor(render_scene(scene_, irradiance, split));
      cached_irradiance_ = irradiance;
      cached_split_ = split;
      cached_scene_ = scene_;
    }
    response = cached_response_;
  }
  const cv::Rect window(offset_x, offset_y, width, height);
  if ((window & cv::Rect(0, 0, response.cols, response.rows)) != window) return;  // the write hook prevents this
  const cv::Mat dn = model_.expose(response(window), layout_of(format.layout), window.x, window.y, exposure_us,
                                   gain_db, frame_index_++);
  ++frames_rendered_;

  auto payload = std::make_shared<std::vector<std::uint8_t>>(format.frame_bytes(width, height));
  std::uint8_t* out = payload->data();
  const int adc_bits = model_.options().adc_bits;
  const auto count = static_cast<std::size_t>(width) * height * dn.channels();
  const auto* in = dn.ptr<std::uint16_t>();  // continuous: freshly allocated
  if (format.bytes_per_sample == 1) {
    for (std::size_t i = 0; i < count; ++i) out[i] = static_cast<std::uint8_t>(in[i] >> (adc_bits - 8));
  } else {
    const int shift = format.significant_bits == 12 ? 0 : 16 - adc_bits;
    for (std::size_t i = 0; i < count; ++i) {
      const auto v = static_cast<std::uint16_t>(in[i] << shift);
      std::memcpy(out + 2 * i, &v, 2);  // little-endian, as GigE Vision pixel data
    }
  }
  if (chunks) append_chunks(*payload, trigger_count);
  block.payload = std::move(payload);
  device_->send_block(block);
}

void CameraSimulator::set_scene(std::shared_ptr<const Scene> scene) {
  if (!scene) throw std::invalid_argument("CameraSimulator::set_scene: null scene");
  check_view(*scene);
  std::lock_guard lock(render_mutex_);
  scene_ = std::move(scene);
}

void CameraSimulator::set_skin_scene_options(std::shared_ptr<const Scene> skin, const SkinSceneOptions& options) {
  if (!skin) throw std::invalid_argument("CameraSimulator::set_skin_scene_options: null scene");
  if (skin->width() != (options.column_count ? options.column_count : options.width) ||
      skin->height() != (options.row_count ? options.row_count : options.height))
    throw std::invalid_argument("CameraSimulator::set_skin_scene_options: the scene is not make_skin_scene(options)");
  std::lock_guard lock(render_mutex_);
  skin_scene_ = std::move(skin);
  skin_scene_options_ = options;
  cached_response_ = cv::Mat();
}

// Called with render_mutex_ held (skin_scene_).
cv::Mat CameraSimulator::render_scene(const std::shared_ptr<const Scene>& scene, const spectral::Spectrum& irradiance,
                                      const std::optional<PolarisedIrradiance>& split) const {
  if (!split || !options_.analyser) return scene->render(model_.weights(irradiance));  // as before
  const CameraAnalyser& analyser = *options_.analyser;
  if (scene != skin_scene_ || !skin_scene_options_) {  // a depolarising target: T_A of the light
    const spectral::Spectrum light = split->unpolarised + split->cross + split->parallel;  // one reading
    return scene->render(model_.weights(light * analyser.film.transmission()));
  }
  PolarisedSphere sphere;
  sphere.light_film = split->light_film;
  sphere.analyser_film = analyser.film;
  sphere.view_angle_deg = analyser.view_angle_deg;
  sphere.cross_leak = analyser.cross_leak;
  sphere.light_film_in_illumination = true;
  cv::Mat sum;
  const std::pair<const spectral::Spectrum*, drivers::Polarisation> parts[] = {
      {&split->unpolarised, drivers::Polarisation::kUnpolarised},
      {&split->cross, drivers::Polarisation::kCross},
      {&split->parallel, drivers::Polarisation::kParallel}};
  for (const auto& [light, state] : parts) {
    if (!any_light(*light)) continue;
    const cv::Mat part = render_polarised_skin(*scene, *skin_scene_options_, model_.weights(*light), state, sphere);
    if (sum.empty()) sum = part;
    else sum += part;
  }
  if (sum.empty()) return scene->render(model_.weights(irradiance));  // dark: no light in any state
  return sum;
}

void CameraSimulator::set_exposure_hook(std::function<void()> hook) {
  std::lock_guard lock(render_mutex_);
  exposure_hook_ = std::move(hook);
}

std::string CameraSimulator::address() const { return device_->address(); }

void CameraSimulator::set_faults(const GvspFaultOptions& faults) {
  device_->set_faults(faults);
  options_.faults = faults;
}

void CameraSimulator::set_packet_loss_ratio(double ratio) {
  GvspFaultOptions faults;
  faults.loss_probability = ratio;
  faults.seed = options_.faults.seed;
  set_faults(faults);
}

GigeVisionDeviceCounters CameraSimulator::device_counters() const { return device_->counters(); }

void CameraSimulator::power_off() {
  if (!device_->running()) return;
  stop_acquisition_thread();  // no frame is being rendered after this
  device_->stop();
}

void CameraSimulator::power_on() {
  if (device_->running()) return;
  device_->start();
  apply_power_on_registers();
  start_acquisition_thread();
}

bool CameraSimulator::powered() const { return device_->running(); }

void CameraSimulator::pulse_trigger_input() {
  std::lock_guard lock(acquisition_mutex_);
  if (acquiring_ && trigger_on_ && trigger_source_ == reg::kSourceLine0) accept_trigger_locked();
}

cv::Mat CameraSimulator::sensor_response(const spectral::Spectrum& irradiance) const {
  std::shared_ptr<const Scene> scene;
  {
    std::lock_guard lock(render_mutex_);
    scene = scene_;
  }
  return to_sensor(scene->render(model_.weights(irradiance)));
}

cv::Mat CameraSimulator::sensor_response_now() const {
  const spectral::Spectrum irradiance = illumination_->irradiance_now();
  const std::optional<PolarisedIrradiance> split =
      options_.analyser ? illumination_->polarised_irradiance_now() : std::nullopt;
  std::lock_guard lock(render_mutex_);
  return to_sensor(render_scene(scene_, irradiance, split));
}

void CameraSimulator::check_view(const Scene& scene) const {
  if (!options_.view) return;
  try {
    patch_to_image_homography(*options_.view,
                              {scene.width(), scene.height(), options_.patch_width_mm / scene.width()});
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("CameraSimulator " + options_.serial + ": " + e.what());
  }
}

cv::Mat CameraSimulator::to_sensor(const cv::Mat& at_scene) const {
  if (options_.view) return render_view(at_scene, *options_.view, options_.patch_width_mm / at_scene.cols);
  cv::Mat at_sensor;
  cv::resize(at_scene, at_sensor, cv::Size(options_.sensor_width, options_.sensor_height), 0, 0, cv::INTER_LINEAR);
  return at_sensor;
}

}  // namespace chromo::simulators
