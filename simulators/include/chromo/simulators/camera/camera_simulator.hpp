#pragma once
// CameraSimulator: a real GigE Vision camera on its own loopback address
// (the project's GigeVisionDevice, gige_vision_device.hpp), whose frames are
// the virtual lab's scene rendered under whatever the SphereIllumination
// emits at the moment of exposure, through the CameraModel (Bayer mosaic,
// noise, 12-bit ADC).
//
// GenICam description: the simulator's own (camera_registers.hpp,
// docs/protocols/gige-vision.md), served from device memory: SensorWidth/
// Height, Width/Height/OffsetX/OffsetY, PixelFormat (Mono8/12/16,
// BayerRG8/12/16, RGB8; 12-bit formats in 16-bit containers), PayloadSize,
// AcquisitionMode (Continuous, SingleFrame), AcquisitionStart/Stop,
// AcquisitionFrameRate, TriggerSelector (FrameStart), TriggerMode,
// TriggerSource (Line0, Software), TriggerActivation, TriggerSoftware,
// ExposureTime (us), Gain (dB, register in hundredths of a dB).
//
// Pixel encoding of the 12-bit ADC value: 8-bit formats carry DN >> 4,
// *12 formats DN, *16 formats DN << 4.
//
// Frames: while acquiring, one frame per period (TriggerMode Off) or per
// trigger (TriggerMode On: TriggerSoftware with TriggerSource Software, or
// pulse_trigger_input() with TriggerSource Line0). On each exposure the
// simulator calls the exposure hook (the LED simulator's hardware trigger
// input, if attached), then reads SphereIllumination::irradiance_now(),
// renders the scene (response cached while the irradiance is unchanged),
// brings it to the sensor (options.view: the camera's perspective view of
// the planar patch, camera_view.hpp; none: resampled bilinearly to fill the
// sensor), crops the ROI and reads it out
// through the CameraModel. Frame k of a power cycle uses noise seed
// (CameraModelOptions::seed, k).
//
// Network: GVCP on <address>:3956, GVSP from the same address. options.address
// empty = an address picked at random in 127.77.0.0/16 (address() says which),
// so any number of simulators run at once on one machine; an explicit
// address must lie in 127.0.0.0/8. The constructor throws std::runtime_error
// when the address is taken. Nothing is written to disk.
//
// Triggers: the camera counts the FrameStart triggers it receives while
// acquiring with TriggerMode On (Line0 edges or TriggerSoftware commands,
// whichever TriggerSource says), from 1 after each AcquisitionStart; with
// ChunkModeActive and ChunkEnable[TriggerCount] every triggered frame carries
// the count of the trigger it answered as GVSP chunk data (ChunkTriggerCount).
// set_trigger_faults() makes the camera ignore chosen triggers (counted, no
// exposure, no frame), as a camera that misses a trigger does.
//
// Faults: set_faults() (GvspFaultOptions: packet loss, reordering, delay on
// first transmissions; resend requests are answered from the last 8 blocks)
// with device_counters() saying what happened; set_packet_loss_ratio(r) is
// set_faults with loss only. power_off()/power_on() make the camera
// disappear (control and stream channels closed) and come back on the same
// address with power-on defaults, as a power cycle.
//
// Thread rules: all methods from one control thread, except
// pulse_trigger_input() and the read-only accessors (any thread). Rendering
// runs on the simulator's acquisition thread; the illumination and the
// exposure hook are called from that thread. Lifetime: the illumination and
// scene are shared_ptr'd; destroying the simulator stops acquisition and
// closes the sockets before returning.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <condition_variable>
#include <deque>
#include <random>
#include <thread>
#include <string>
#include <vector>

#include "chromo/drivers/camera.hpp"
#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/simulators/camera/gige_vision_device.hpp"
#include "chromo/simulators/polarisation/polariser_optics.hpp"
#include "chromo/simulators/scene/camera_view.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/simulators/sphere_illumination.hpp"

namespace chromo::simulators {

// The analyser film on the camera's lens and what its view sees of the
// sphere's polariser pattern (cross_polarisation_leak; lab_camera_analyser
// derives both from a pose).
struct CameraAnalyser {
  PolariserFilm film;
  double view_angle_deg = 0;  // the camera's angle from the patch normal (the sheen's F(θ))
  double cross_leak = 0;      // cross_polarisation_leak(...).lobe_leak; 0 at the design view

  bool IsValid(std::string* error) const;
};

struct CameraSimulatorOptions {
  std::string serial = "CHROMO-SIM-CAM";  // 1-15 characters
  std::string address;                    // "" = random in 127.77.0.0/16; else 127.a.b.c
  int sensor_width = 1024;
  int sensor_height = 1024;
  drivers::PixelFormat pixel_format = drivers::PixelFormat::kMono8;  // power-on PixelFormat
  CameraModelOptions camera_model;
  GvspFaultOptions faults;
  std::uint16_t first_block_id = 1;  // GVSP block id after power-on (tests: 65400 crosses the 16-bit wrap soon)
  // true: frames are a moving test pattern (byte (x + y + frame) mod 256 in
  // every sample), without the scene, the illumination or the noise model:
  // the transport alone, for benches of the link.
  bool test_pattern = false;
  // Where the camera stands and its lens: the sensor sees the scene as a
  // planar patch patch_width_mm wide (its pixels square) in perspective,
  // dark where there is no patch; view->intrinsics' size is the sensor's.
  // None: the scene resampled to fill the sensor (a square-on camera
  // framing the patch exactly, as before views existed).
  std::optional<CameraView> view;
  double patch_width_mm = 80;
  // The analyser in front of the lens; none: no analyser (see "Polarisation" above).
  std::optional<CameraAnalyser> analyser;

  bool IsValid(std::string* error) const;
};

// Triggers the camera receives but does not answer (no exposure, no frame;
// the trigger is still counted). Numbers are the camera's triggers since the
// simulator was made (1 = the first trigger received), whatever acquisition
// restarts or power cycles happen in between: triggers_received() counts them.
struct TriggerFaultOptions {
  std::vector<std::uint64_t> ignore_triggers;  // these trigger numbers
  double ignore_probability = 0;               // and each other trigger with this probability, [0, 0.5]
  std::uint64_t seed = 1;                      // the dice

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

  // Throws std::invalid_argument (nothing changed) for a null scene or one
  // the view does not have wholly in front of the camera.
  void set_scene(std::shared_ptr<const Scene> scene);
  // Names the scene that is make_skin_scene(options): with an analyser on a
  // polarised sphere it is rendered with its surface layer. Throws
  // std::invalid_argument for a null scene or one whose size is not the options'.
  void set_skin_scene_options(std::shared_ptr<const Scene> skin, const SkinSceneOptions& options);
  // Called at the start of every exposure, on the simulator's thread.
  void set_exposure_hook(std::function<void()> hook);

  // "127.a.b.c": where GVCP listens (the driver's AravisCameraOptions::address).
  std::string address() const;
  void set_faults(const GvspFaultOptions& faults);  // std::invalid_argument when invalid
  void set_trigger_faults(const TriggerFaultOptions& faults);  // std::invalid_argument when invalid; any thread
  std::uint64_t triggers_received() const { return triggers_received_; }  // since construction
  std::uint64_t triggers_ignored() const { return triggers_ignored_; }    // of them, not answered (faults)
  void set_packet_loss_ratio(double ratio);         // 0-0.5, other faults off
  GigeVisionDeviceCounters device_counters() const;
  void power_off();
  void power_on();
  bool powered() const;

  // An edge on the trigger input: one frame when the camera is in TriggerMode
  // On with TriggerSource Line0 and acquiring; ignored otherwise.
  void pulse_trigger_input();

  // Noise-free channel responses (CV_32FC3, R G B) at sensor resolution under
  // `irradiance`: what expose() feeds the CameraModel (tests compare with it).
  cv::Mat sensor_response(const spectral::Spectrum& irradiance) const;
  // The same under the illumination's light of this moment, polarisation
  // included: what the next exposure feeds the CameraModel.
  cv::Mat sensor_response_now() const;

  std::uint64_t frames_rendered() const { return frames_rendered_; }

 private:
  // The scene-resolution response to `irradiance` (split: its polarised parts, if any).
  cv::Mat render_scene(const std::shared_ptr<const Scene>& scene, const spectral::Spectrum& irradiance,
                       const std::optional<PolarisedIrradiance>& split) const;
  // A scene-resolution response brought to the sensor (view or resampling).
  cv::Mat to_sensor(const cv::Mat& at_scene) const;
  // Throws std::invalid_argument when the view does not see `scene` wholly in front.
  void check_view(const Scene& scene) const;
  void apply_power_on_registers();
  std::uint16_t on_register_write(std::uint32_t address, std::uint32_t value,
                                  const GigeVisionDevice::RegisterReader& read);
  void acquisition_loop();
  void produce_frame(std::uint64_t trigger_count);
  // A trigger reached the camera (acquisition_mutex_ held): counts it and
  // queues its frame unless the faults say to ignore it.
  void accept_trigger_locked();
  void start_acquisition_thread();
  void stop_acquisition_thread();

  CameraSimulatorOptions options_;
  CameraModel model_;
  std::shared_ptr<const SphereIllumination> illumination_;
  std::unique_ptr<GigeVisionDevice> device_;

  mutable std::mutex render_mutex_;  // scene, hook, cache
  std::shared_ptr<const Scene> scene_;
  std::function<void()> exposure_hook_;
  spectral::Spectrum cached_irradiance_;
  std::optional<PolarisedIrradiance> cached_split_;
  std::shared_ptr<const Scene> skin_scene_;      // set_skin_scene_options
  std::optional<SkinSceneOptions> skin_scene_options_;
  std::shared_ptr<const Scene> cached_scene_;
  cv::Mat cached_response_;  // sensor resolution

  // Acquisition state, mirrored from the registers by the write hook. Lock
  // order: the device's lock (hook) before acquisition_mutex_; the
  // acquisition thread calls the device only without acquisition_mutex_.
  std::mutex acquisition_mutex_;
  std::condition_variable acquisition_cv_;
  bool quit_ = false;
  bool acquiring_ = false;
  bool single_frame_ = false;
  bool trigger_on_ = false;
  std::uint32_t trigger_source_ = 1;
  std::uint32_t frame_period_us_ = 100000;
  std::deque<std::uint64_t> pending_triggers_;  // counts (since AcquisitionStart) of triggers to answer
  std::uint64_t trigger_count_ = 0;             // since AcquisitionStart
  TriggerFaultOptions trigger_faults_;
  std::mt19937_64 trigger_dice_;
  std::atomic<std::uint64_t> triggers_received_{0}, triggers_ignored_{0};
  std::thread acquisition_thread_;

  std::atomic<std::uint64_t> frames_rendered_{0};
  std::uint64_t frame_index_ = 0;  // per power cycle, on the acquisition thread
};

}  // namespace chromo::simulators
