#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/drivers/camera.hpp"

#include <arv.h>
#include <unistd.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace chromo::simulators {
namespace {

// Registers of Aravis' fake camera (arvfakecamera.h) and ours.
constexpr guint32 kRegisterSensorWidth = 0x11c;
constexpr guint32 kRegisterSensorHeight = 0x118;
constexpr guint32 kRegisterOffsetX = 0x130;
constexpr guint32 kRegisterOffsetY = 0x134;
constexpr guint32 kRegisterTriggerMode = 0x300;
constexpr guint32 kRegisterFakeTriggerSource = 0x304;  // pinned to 1: the fake thread fires on 0x30c
constexpr guint32 kRegisterTriggerSoftware = 0x30c;
constexpr guint32 kRegisterTriggerSource = 0x3f4;      // our TriggerSource: 0 = Line0, 1 = Software

void replace_once(std::string& text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos || text.find(from, at + 1) != std::string::npos)
    throw std::runtime_error("camera simulator: Aravis' fake-camera GenICam XML changed (no unique '" + from +
                             "'); update camera_simulator.cpp");
  text.replace(at, from.size(), to);
}

// Aravis' built-in fake-camera description, amended (see the header).
std::string simulator_genicam_xml() {
  ArvFakeCamera* probe = arv_fake_camera_new("probe");
  size_t size = 0;
  const char* xml = arv_fake_camera_get_genicam_xml(probe, &size);
  std::string text(xml, size);
  g_object_unref(probe);

  replace_once(text, "<pFeature>GainRaw</pFeature>", "<pFeature>Gain</pFeature>");
  const auto gain_begin = text.find("<Integer Name=\"GainRaw\"");
  const auto gain_end = text.find("</Integer>", gain_begin);
  if (gain_begin == std::string::npos || gain_end == std::string::npos)
    throw std::runtime_error("camera simulator: no GainRaw in Aravis' fake-camera XML");
  text.replace(gain_begin, gain_end + std::strlen("</Integer>") - gain_begin,
               "<Float Name=\"Gain\" NameSpace=\"Standard\">\n"
               "\t\t<Description>Analog gain in dB.</Description>\n"
               "\t\t<pValue>GainConverter</pValue>\n\t\t<Min>0.0</Min>\n\t\t<Max>24.0</Max>\n\t\t<Unit>dB</Unit>\n"
               "\t</Float>\n\n"
               "\t<Converter Name=\"GainConverter\" NameSpace=\"Custom\">\n"
               "\t\t<FormulaTo>FROM * 100</FormulaTo>\n\t\t<FormulaFrom>TO / 100</FormulaFrom>\n"
               "\t\t<pValue>GainRawRegister</pValue>\n\t</Converter>");
  replace_once(text, "<pValue>PixelFormatRegister</pValue>",
               "<EnumEntry Name=\"Mono12\" NameSpace=\"Standard\">\n\t\t\t<Value>17825797</Value>\n\t\t</EnumEntry>\n"
               "\t\t<EnumEntry Name=\"BayerRG12\" NameSpace=\"Standard\">\n\t\t\t<Value>17825809</Value>\n\t\t</EnumEntry>\n"
               "\t\t<EnumEntry Name=\"BayerRG16\" NameSpace=\"Standard\">\n\t\t\t<Value>17825839</Value>\n\t\t</EnumEntry>\n"
               "\t\t<pValue>PixelFormatRegister</pValue>");
  const auto source_begin = text.find("<IntReg Name=\"TriggerSourceRegister\"");
  if (source_begin == std::string::npos) throw std::runtime_error("camera simulator: no TriggerSourceRegister in XML");
  const auto address = text.find("<Address>0x304</Address>", source_begin);
  if (address == std::string::npos) throw std::runtime_error("camera simulator: TriggerSourceRegister moved");
  text.replace(address, std::strlen("<Address>0x304</Address>"), "<Address>0x3f4</Address>");
  return text;
}

SensorLayout layout_of(drivers::ColourLayout layout) {
  switch (layout) {
    case drivers::ColourLayout::kBayerRGGB: return SensorLayout::kBayerRGGB;
    case drivers::ColourLayout::kRgb: return SensorLayout::kThreeChannel;
    case drivers::ColourLayout::kMono: return SensorLayout::kMono;
  }
  return SensorLayout::kMono;
}

}  // namespace

struct CameraSimulator::Fake {
  ArvGvFakeCamera* gv = nullptr;
  ~Fake() {
    if (gv != nullptr) g_object_unref(gv);
  }
  ArvFakeCamera* camera() const { return arv_gv_fake_camera_get_fake_camera(gv); }
};

bool CameraSimulatorOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (serial.empty() || serial.size() > 15) return fail("serial must be 1-15 characters (GigE Vision bootstrap)");
  if (sensor_width < 16 || sensor_height < 16 || sensor_width > 4096 || sensor_height > 4096)
    return fail("sensor size must be 16-4096 pixels");
  return camera_model.IsValid(error);
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
  genicam_path_ = ((options_.genicam_dir.empty() ? std::filesystem::temp_directory_path() : options_.genicam_dir) /
                   ("chromo-camera-sim-" + std::to_string(::getpid()) + "-" + options_.serial + ".xml"))
                      .string();
  start_fake();
}

CameraSimulator::~CameraSimulator() { power_off(); }

void CameraSimulator::start_fake() {
  auto fake = std::make_unique<Fake>();
  // Aravis reads the GenICam file when the fake camera is made: the file
  // exists only for that call.
  {
    std::ofstream xml(genicam_path_);
    xml << simulator_genicam_xml();
    if (!xml.flush()) throw std::runtime_error("camera simulator " + options_.serial + ": cannot write " + genicam_path_);
  }
  fake->gv = arv_gv_fake_camera_new_full(options_.interface_address.c_str(), options_.serial.c_str(),
                                         genicam_path_.c_str());
  std::error_code ignored;
  std::filesystem::remove(genicam_path_, ignored);
  if (fake->gv == nullptr || !arv_gv_fake_camera_is_running(fake->gv))
    throw std::runtime_error("camera simulator " + options_.serial + ": cannot listen for GigE Vision on " +
                             options_.interface_address + ":" + std::to_string(kGvcpPort) +
                             " (is another camera simulator running?)");
  ArvFakeCamera* camera = fake->camera();
  arv_fake_camera_write_register(camera, kRegisterSensorWidth, options_.sensor_width);
  arv_fake_camera_write_register(camera, kRegisterSensorHeight, options_.sensor_height);
  arv_fake_camera_write_register(camera, 0x100, std::min(512, options_.sensor_width));   // Width
  arv_fake_camera_write_register(camera, 0x104, std::min(512, options_.sensor_height));  // Height
  arv_fake_camera_write_register(camera, kRegisterFakeTriggerSource, 1);
  arv_fake_camera_write_register(camera, kRegisterTriggerSource, 1);
  g_object_set(fake->gv, "gvsp-lost-ratio", packet_loss_ratio_, nullptr);
  frame_index_ = 0;
  arv_fake_camera_set_fill_pattern(
      camera,
      [](ArvBuffer* buffer, void* self, guint32 exposure_us, guint32 gain, ArvPixelFormat format) {
        fill_frame(buffer, self, exposure_us, gain, static_cast<std::uint32_t>(format));
      },
      this);
  live_camera_ = camera;
  fake_ = std::move(fake);
}

void CameraSimulator::set_scene(std::shared_ptr<const Scene> scene) {
  if (!scene) throw std::invalid_argument("CameraSimulator::set_scene: null scene");
  std::lock_guard lock(render_mutex_);
  scene_ = std::move(scene);
}

void CameraSimulator::set_exposure_hook(std::function<void()> hook) {
  std::lock_guard lock(render_mutex_);
  exposure_hook_ = std::move(hook);
}

void CameraSimulator::set_packet_loss_ratio(double ratio) {
  if (!(ratio >= 0 && ratio <= 1)) throw std::invalid_argument("packet loss ratio must be 0-1");
  packet_loss_ratio_ = ratio;
  if (fake_) g_object_set(fake_->gv, "gvsp-lost-ratio", ratio, nullptr);
}

void CameraSimulator::power_off() {
  fake_.reset();  // joins the fake camera's thread: no frame is being rendered after this
  live_camera_ = nullptr;
}

void CameraSimulator::power_on() {
  if (!fake_) start_fake();
}

bool CameraSimulator::powered() const { return fake_ != nullptr; }

void CameraSimulator::pulse_trigger_input() {
  if (!fake_) return;
  guint32 mode = 0, source = 1;
  arv_fake_camera_read_register(fake_->camera(), kRegisterTriggerMode, &mode);
  arv_fake_camera_read_register(fake_->camera(), kRegisterTriggerSource, &source);
  if (mode == 1 && source == 0) arv_fake_camera_write_register(fake_->camera(), kRegisterTriggerSoftware, 1);
}

cv::Mat CameraSimulator::sensor_response(const spectral::Spectrum& irradiance) const {
  std::shared_ptr<const Scene> scene;
  {
    std::lock_guard lock(render_mutex_);
    scene = scene_;
  }
  const cv::Mat at_scene = scene->render(model_.weights(irradiance));
  cv::Mat at_sensor;
  cv::resize(at_scene, at_sensor, cv::Size(options_.sensor_width, options_.sensor_height), 0, 0, cv::INTER_LINEAR);
  return at_sensor;
}

void CameraSimulator::fill_frame(void* buffer, void* self, std::uint32_t exposure_us, std::uint32_t gain_centi_db,
                                 std::uint32_t pixel_format) {
  static_cast<CameraSimulator*>(self)->render_into(buffer, exposure_us, gain_centi_db, pixel_format);
}

void CameraSimulator::render_into(void* arv_buffer, std::uint32_t exposure_us, std::uint32_t gain_centi_db,
                                  std::uint32_t pixel_format) {
  auto* buffer = static_cast<ArvBuffer*>(arv_buffer);
  std::function<void()> hook;
  {
    std::lock_guard lock(render_mutex_);
    hook = exposure_hook_;
  }
  if (hook) hook();  // the LED controller's trigger input sees the exposure start
  const spectral::Spectrum irradiance = illumination_->irradiance_now();
  cv::Mat response;
  {
    std::lock_guard lock(render_mutex_);
    if (cached_response_.empty() || cached_scene_ != scene_ ||
        !(cached_irradiance_.values() == irradiance.values()).all()) {
      const cv::Mat at_scene = scene_->render(model_.weights(irradiance));
      cv::resize(at_scene, cached_response_, cv::Size(options_.sensor_width, options_.sensor_height), 0, 0,
                 cv::INTER_LINEAR);
      cached_irradiance_ = irradiance;
      cached_scene_ = scene_;
    }
    response = cached_response_;
  }
  const int width = arv_buffer_get_image_width(buffer), height = arv_buffer_get_image_height(buffer);
  guint32 offset_x = 0, offset_y = 0;
  auto* camera = static_cast<ArvFakeCamera*>(live_camera_.load());
  arv_fake_camera_read_register(camera, kRegisterOffsetX, &offset_x);
  arv_fake_camera_read_register(camera, kRegisterOffsetY, &offset_y);
  const cv::Rect window(static_cast<int>(offset_x), static_cast<int>(offset_y), width, height);
  if ((window & cv::Rect(0, 0, response.cols, response.rows)) != window) return;  // GenICam limits prevent this
  const auto known = drivers::pixel_format_from_pfnc(pixel_format);
  if (!known) return;  // the GenICam enumeration offers only the table's formats
  const drivers::PixelFormatInfo& format = drivers::pixel_format_info(*known);
  const cv::Mat dn = model_.expose(response(window), layout_of(format.layout), window.x, window.y, exposure_us,
                                   gain_centi_db / 100.0, frame_index_++);
  ++frames_rendered_;

  std::size_t ignored = 0;
  auto* out = static_cast<std::uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, &ignored)));
  if (out == nullptr) return;
  const int adc_bits = model_.options().adc_bits;
  const int channels = dn.channels();
  const auto count = static_cast<std::size_t>(width) * height * channels;
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
}

}  // namespace chromo::simulators
