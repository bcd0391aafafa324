#pragma once
// CameraSimulator: a real GigE Vision camera on loopback, built on Aravis'
// ArvGvFakeCamera, whose frames are the virtual lab's scene rendered under
// whatever the SphereIllumination emits at the moment of exposure, through the
// CameraModel (Bayer mosaic, noise, 12-bit ADC).
//
// GenICam description: Aravis' own fake-camera XML, taken from the library at
// run time and amended (written to a temporary file for
// arv_gv_fake_camera_new_full): a float `Gain` in dB (register 0x110 holds
// hundredths of a dB) instead of GainRaw; Mono12, BayerRG12 and BayerRG16
// pixel formats (16-bit containers); TriggerSource moved to register 0x3f4 so
// that the hardware trigger line can be simulated (pulse_trigger_input()).
//
// Pixel encoding of the 12-bit ADC value: 8-bit formats carry DN >> 4,
// *12 formats DN, *16 formats DN << 4.
//
// Frames: on each exposure the simulator calls the exposure hook (the LED
// simulator's hardware trigger input, if attached), then reads
// SphereIllumination::irradiance_now(), renders the scene (response cached
// while the irradiance is unchanged), resamples it bilinearly to the sensor,
// crops the ROI and reads it out through the CameraModel. Frame k of a
// power cycle uses noise seed (CameraModelOptions::seed, k).
//
// Network: GVCP on <interface_address>:3956 (fixed by GigE Vision), so only
// one simulator per address and machine at a time (tests take the ctest
// resource lock "gige_loopback"). The constructor throws std::runtime_error
// when the port is taken.
//
// Faults: set_packet_loss_ratio() drops that fraction of GVSP packets (the
// fake camera ignores resend requests, so lost packets stay lost);
// power_off()/power_on() make the camera disappear (control and stream
// channels closed) and come back with power-on defaults, as a power cycle.
//
// Thread rules: all methods from one control thread; rendering runs on the
// fake camera's thread; the illumination and the exposure hook are called
// from that thread. Lifetime: the illumination and scene are shared_ptr'd.

#include <atomic>
#include <cstdint>
#include <functional>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>

#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/simulators/sphere_illumination.hpp"

namespace chromo::simulators {

struct CameraSimulatorOptions {
  std::string serial = "CHROMO-SIM-CAM";
  std::string interface_address = "127.0.0.1";
  int sensor_width = 1024;
  int sensor_height = 1024;
  CameraModelOptions camera_model;
  // Where the GenICam XML Aravis's fake camera reads is written for the
  // moment it starts (the file is removed as soon as the camera has read it,
  // so a killed process leaves nothing); empty = the system's temporary folder.
  std::filesystem::path genicam_dir;

  bool IsValid(std::string* error) const;
};

class CameraSimulator {
 public:
  static constexpr int kGvcpPort = 3956;

  CameraSimulator(CameraSimulatorOptions options, std::shared_ptr<const SphereIllumination> illumination,
                  std::shared_ptr<const Scene> scene);
  ~CameraSimulator();
  CameraSimulator(const CameraSimulator&) = delete;
  CameraSimulator& operator=(const CameraSimulator&) = delete;

  const CameraSimulatorOptions& options() const { return options_; }
  const CameraModel& camera_model() const { return model_; }

  void set_scene(std::shared_ptr<const Scene> scene);
  // Called at the start of every exposure, on the simulator's thread.
  void set_exposure_hook(std::function<void()> hook);

  void set_packet_loss_ratio(double ratio);  // 0-1
  void power_off();
  void power_on();
  bool powered() const;

  // An edge on the trigger input: one frame when the camera is in TriggerMode
  // On with TriggerSource Line0 and acquiring; ignored otherwise.
  void pulse_trigger_input();

  // Noise-free channel responses (CV_32FC3, R G B) at sensor resolution under
  // `irradiance`: what expose() feeds the CameraModel (tests compare with it).
  cv::Mat sensor_response(const spectral::Spectrum& irradiance) const;

  std::uint64_t frames_rendered() const { return frames_rendered_; }

 private:
  struct Fake;
  static void fill_frame(void* buffer, void* self, std::uint32_t exposure_us, std::uint32_t gain_centi_db,
                         std::uint32_t pixel_format);
  void render_into(void* buffer, std::uint32_t exposure_us, std::uint32_t gain_centi_db, std::uint32_t pixel_format);
  void start_fake();

  CameraSimulatorOptions options_;
  CameraModel model_;
  std::shared_ptr<const SphereIllumination> illumination_;
  std::string genicam_path_;

  mutable std::mutex render_mutex_;  // scene, hook, cache
  std::shared_ptr<const Scene> scene_;
  std::function<void()> exposure_hook_;
  spectral::Spectrum cached_irradiance_;
  std::shared_ptr<const Scene> cached_scene_;
  cv::Mat cached_response_;  // sensor resolution

  std::unique_ptr<Fake> fake_;
  // The fake camera the render callback reads registers from (ArvFakeCamera*);
  // it stays valid while fake_ is being destroyed and its thread joined.
  std::atomic<void*> live_camera_{nullptr};
  double packet_loss_ratio_ = 0;
  std::atomic<std::uint64_t> frames_rendered_{0};
  std::uint64_t frame_index_ = 0;  // per power cycle, on the fake camera's thread
};

}  // namespace chromo::simulators
