// chromo-sim: the whole virtual lab in one process, for hardware-in-the-loop
// use. Starts the device simulators on their real protocols, prints where
// each one listens, and runs until Ctrl-C (SIGINT) or SIGTERM.
//
// Devices: the LED controller simulator (Modbus TCP on 127.0.0.1 and Modbus
// RTU on a pseudo-terminal; its HID device side and the spectrometer sit
// behind in-process seams and cannot be reached from another process), and
// the GigE Vision camera simulators, each on its own loopback address
// 127.x.y.z:3956 (--camera-address or one picked at random in
// 127.77.0.0/16), which render their view of the scene under what the LED
// lab emits. One camera from the --camera-*/--sensor-* options, or every
// camera of --cameras FILE (a JSON list, as chromod's virtual_lab.cameras:
// simulators/camera/lab_cameras.hpp, docs/config.md). The controller's
// trigger output is wired to every camera's Line0 (the trigger master,
// docs/camera.md) and the first camera's exposures raise the controller's
// hardware trigger input. --fixed-light replaces the LED lab's light by a
// fixed spectrum (the LED controller still runs).
#include <CLI/CLI.hpp>

#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <vector>

#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/camera/fixed_illumination.hpp"
#include "chromo/simulators/camera/lab_cameras.hpp"
#include "chromo/files/bounded_read.hpp"
#include "chromo/simulators/leds/led_controller_simulator.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/table.hpp"

namespace {

using namespace chromo;

struct SimArguments {
  std::string camera_serial = "CHROMO-SIM-CAM";
  std::string camera_address;  // empty: random in 127.77.0.0/16
  int sensor_width = 1024, sensor_height = 1024;
  int scene_size = 512;
  std::uint64_t seed = 1;
  std::string fixed_light;  // empty: the LED lab's light
  int modbus_port = 0;
  double irradiance_peak = 1.0;
  bool white_target = false;
  bool polarisers = false;  // banks on all six LED types, analysers on the cameras
  double packet_loss = 0;
  std::string camera_sensitivity = "nikon_d5100";
  std::string cameras_file;  // JSON list of cameras; empty: one camera from the options above
  double patch_width_mm = 80;
  simulators::SubsurfaceSpread subsurface;  // --subsurface: each wavelength of the skin blurred by σ(λ)
};

// The cameras to start: the --cameras list, or one from the single-camera options.
std::vector<simulators::LabCamera> lab_cameras_of(const SimArguments& args) {
  if (args.cameras_file.empty()) {
    simulators::LabCamera camera;
    camera.serial = args.camera_serial;
    camera.address = args.camera_address;
    camera.sensor_width = args.sensor_width;
    camera.sensor_height = args.sensor_height;
    camera.pixel_format = drivers::PixelFormat::kMono8;  // the power-on PixelFormat, as before
    return {camera};
  }
  std::string text;
  try {
    text = files::read_text_file(args.cameras_file, "camera list");
  } catch (const files::InputFileError& e) {
    throw std::invalid_argument(e.what());
  }
  const auto json = nlohmann::json::parse(text, nullptr, false);
  if (json.is_discarded()) throw std::invalid_argument(args.cameras_file + ": not valid JSON");
  try {
    return simulators::read_lab_cameras(json);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(args.cameras_file + ": cameras" + e.what());
  }
}

// The skin's highlight lobe for the posed cameras' cross leak (as chromod's virtual lab).
constexpr double kPolariserRoughnessRad = 0.3;

int run(const SimArguments& args) {
  // Block the stop signals before any thread starts, then wait for them here.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  // The camera list first: a bad one is refused before anything starts.
  const std::vector<simulators::LabCamera> lab_cameras = lab_cameras_of(args);
  std::shared_ptr<const simulators::SphereIllumination> fixed_light;
  if (!args.fixed_light.empty()) {
    spectral::Spectrum light = spectral::illuminant_by_name_or_file(args.fixed_light);
    light *= args.irradiance_peak / light.max();
    fixed_light = std::make_shared<simulators::FixedSpectrumIllumination>(light);
  }
  const spectral::CameraSensitivity sensitivity =
      args.camera_sensitivity.ends_with(".csv") ? spectral::read_camera_sensitivity(args.camera_sensitivity)
                                                : spectral::builtin_camera(args.camera_sensitivity);

  std::cout << "chromo-sim: building the " << (args.white_target ? "white target" : "skin") << " scene ("
            << args.scene_size << "x" << args.scene_size << ")..." << std::endl;
  std::shared_ptr<const simulators::Scene> scene;
  if (args.white_target) {
    scene = std::make_shared<const simulators::Scene>(
        simulators::make_white_target_scene(args.scene_size, args.scene_size));
  }
  simulators::SkinSceneOptions scene_options;
  scene_options.width = scene_options.height = args.scene_size;
  scene_options.seed = args.seed;
  scene_options.subsurface = args.subsurface;
  if (!args.white_target)
    scene = std::make_shared<const simulators::Scene>(simulators::make_skin_scene(scene_options));

  simulators::LedLabOptions lab_options;
  if (args.polarisers) lab_options.polariser_banks.fill(true);  // docs/polarisation.md: all six types
  simulators::LedControllerSimulator leds(lab_options);
  const int modbus_port = leds.start_modbus_tcp(args.modbus_port);
  const std::string modbus_pty = leds.start_modbus_rtu();
  // The lab outlives the camera simulators (declared first): a non-owning pointer.
  const std::shared_ptr<const simulators::SphereIllumination> lab_light(std::shared_ptr<void>(), &leds.lab());
  std::vector<std::unique_ptr<simulators::CameraSimulator>> cameras;
  for (std::size_t i = 0; i < lab_cameras.size(); ++i) {
    const simulators::LabCamera& lab_camera = lab_cameras[i];
    simulators::CameraSimulatorOptions camera_options = simulators::lab_camera_simulator_options(
        lab_camera, i, args.camera_serial, args.patch_width_mm, args.seed,
        simulators::lab_camera_sensitivity(lab_camera, sensitivity));
    if (args.polarisers) camera_options.analyser = simulators::lab_camera_analyser(lab_camera, kPolariserRoughnessRad);
    cameras.push_back(std::make_unique<simulators::CameraSimulator>(camera_options, fixed_light ? fixed_light : lab_light,
                                                                    scene));
    if (!args.white_target) cameras.back()->set_skin_scene_options(scene, scene_options);
    cameras.back()->set_packet_loss_ratio(args.packet_loss);
    // The trigger master's output → every camera's Line0.
    leds.lab().connect_trigger_output([raw = cameras.back().get()] { raw->pulse_trigger_input(); });
  }
  cameras.front()->set_exposure_hook([&leds] { leds.trigger(); });  // the first camera's exposures → trigger input
  const auto led_info = leds.lab().info();

  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const auto& options = cameras[i]->options();
    std::cout << "camera " << lab_cameras[i].name << ": GigE Vision on " << cameras[i]->address() << ":"
              << simulators::CameraSimulator::kGvcpPort << " serial " << options.serial << " (sensor "
              << options.sensor_width << "x" << options.sensor_height << ", power-on "
              << drivers::pixel_format_name(options.pixel_format) << ", Bayer RG / mono / RGB8 formats, "
              << (options.view ? "posed" : "filled with the patch") << ", packet loss " << args.packet_loss << ")\n";
  }
  std::cout << "led controller: Modbus TCP on 127.0.0.1:" << modbus_port << " unit 1; Modbus RTU on "
            << modbus_pty << " unit 1 (model " << led_info.model << ", serial " << led_info.serial
            << "); trigger output wired to every camera's Line0, trigger input to the first camera's exposures\n";
  std::cout << "light: "
            << (fixed_light ? "fixed " + args.fixed_light + " spectrum (--fixed-light), not the LEDs"
                            : std::string("the LED lab (true LED spectra, drift, warm-up)"))
            << "\n";
  std::cout << "spectrometer, LED HID: in-process only (libusb / hidapi transport seams)\n";
  std::cout << "chromo-sim: running; Ctrl-C stops" << std::endl;

  int signal_number = 0;
  sigwait(&stop_signals, &signal_number);
  std::cout << "chromo-sim: " << (signal_number == SIGINT ? "SIGINT" : "SIGTERM") << ", stopping ("
            << [&] {
                 std::uint64_t frames = 0;
                 for (const auto& camera : cameras) frames += camera->frames_rendered();
                 return frames;
               }()
            << " camera frames rendered)" << std::endl;
  leds.lab().disconnect_trigger_outputs();  // before the cameras go
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"chromo-sim: the Chromosphere virtual lab (device simulators on their real protocols)"};
  SimArguments args;
  app.add_option("--camera-serial", args.camera_serial,
                 "GigE Vision serial number of the (first) camera simulator (with --cameras: camera k > 0 "
                 "without a serial of its own gets the first 13 characters and k)")
      ->capture_default_str();
  auto* cameras = app.add_option("--cameras", args.cameras_file,
                                 "JSON list of cameras to start (as chromod's virtual_lab.cameras, docs/config.md)");
  app.add_option("--patch-width-mm", args.patch_width_mm, "Width of the skin patch posed cameras look at, mm")
      ->check(CLI::Range(0.001, 10000.0))->capture_default_str();
  app.add_option("--sensor-width", args.sensor_width, "Sensor width, pixels (one camera)")
      ->check(CLI::Range(16, 4096))->capture_default_str()->excludes(cameras);
  app.add_option("--sensor-height", args.sensor_height, "Sensor height, pixels (one camera)")
      ->check(CLI::Range(16, 4096))->capture_default_str()->excludes(cameras);
  app.add_option("--scene-size", args.scene_size, "Scene resolution (square), pixels")->check(CLI::Range(16, 2048))->capture_default_str();
  app.add_option("--seed", args.seed, "Seed of the scene and of the camera noise")->capture_default_str();
  app.add_option("--modbus-port", args.modbus_port, "Modbus TCP port of the LED controller (0 = any free port)")
      ->check(CLI::Range(0, 65535))->capture_default_str();
  app.add_option("--fixed-light", args.fixed_light,
                 "Render under a fixed spectrum instead of the LEDs: D65, D50, A or a CSV spectrum file");
  app.add_option("--irradiance-peak", args.irradiance_peak, "Peak of the --fixed-light spectrum (W57 at full drive ~ 1)")
      ->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--camera-sensitivity", args.camera_sensitivity,
                 "Camera spectral sensitivity: nikon_d5100, canon_eos_5d_mark_ii, sony_ilce_7m3 or a CSV "
                 "(wavelength_nm,R,G,B)")
      ->capture_default_str();
  app.add_flag("--white-target", args.white_target, "Show the white reference target instead of skin");
  app.add_flag("--polarisers", args.polarisers,
               "Polarised sphere: cross and parallel banks on all six LED types, an analyser on every camera "
               "(docs/polarisation.md)");
  app.add_flag("--subsurface", args.subsurface.on,
               "Subsurface spread in the skin's photographs: each wavelength of the albedo blurred by a Gaussian of "
               "sigma from --subsurface-blue-px (<= 450 nm) to --subsurface-red-px (>= 700 nm), scene pixels, so "
               "edges and texture soften more in red than in blue (docs/camera.md 'Scene')");
  app.add_option("--subsurface-blue-px", args.subsurface.sigma_blue_px, "Subsurface spread sigma at <= 450 nm, scene pixels")
      ->check(CLI::Range(0.01, 64.0))->capture_default_str();
  app.add_option("--subsurface-red-px", args.subsurface.sigma_red_px, "Subsurface spread sigma at >= 700 nm, scene pixels")
      ->check(CLI::Range(0.01, 64.0))->capture_default_str();
  app.add_option("--camera-address", args.camera_address,
                 "Loopback address of the camera simulator, 127.a.b.c (default: a free one in 127.77.0.0/16)")
      ->excludes(cameras);
  app.add_option("--packet-loss", args.packet_loss,
                 "Fraction of GVSP packets dropped on first transmission (resend requests are answered)")
      ->check(CLI::Range(0.0, 0.5))->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int status = app.exit(e);
    return status == 0 ? 0 : 2;  // --help is not an error; anything else is bad input
  }
  try {
    return run(args);
  } catch (const spectral::DataError& e) {
    std::cerr << "chromo-sim: " << e.what() << "\n";
    return 2;
  } catch (const std::invalid_argument& e) {
    std::cerr << "chromo-sim: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "chromo-sim: " << e.what() << "\n";
    return 1;
  } catch (...) {  // no exception leaves main (issue 19)
    std::cerr << "chromo-sim: unknown exception\n";
    return 1;
  }
}
