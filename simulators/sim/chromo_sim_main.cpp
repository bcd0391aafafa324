// chromo-sim: the whole virtual lab in one process, for hardware-in-the-loop
// use. Starts the device simulators on their real protocols, prints where
// each one listens, and runs until Ctrl-C (SIGINT) or SIGTERM.
//
// Devices: the LED controller simulator (Modbus TCP on 127.0.0.1 and Modbus
// RTU on a pseudo-terminal; its HID device side and the spectrometer sit
// behind in-process seams and cannot be reached from another process), and
// the GigE Vision camera simulator (its own loopback address 127.x.y.z:3956,
// --camera-address or one picked at random in 127.77.0.0/16), which renders the scene
// under what the LED lab emits and raises the LED controller's hardware
// trigger input on every exposure; the controller's trigger output is wired
// to the camera's Line0 (the trigger master, docs/camera.md). --fixed-light replaces the LED lab's light
// by a fixed spectrum (the LED controller still runs).
#include <CLI/CLI.hpp>

#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>

#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/camera/fixed_illumination.hpp"
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
  double packet_loss = 0;
  std::string camera_sensitivity = "nikon_d5100";
};

int run(const SimArguments& args) {
  // Block the stop signals before any thread starts, then wait for them here.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

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
  } else {
    simulators::SkinSceneOptions scene_options;
    scene_options.width = scene_options.height = args.scene_size;
    scene_options.seed = args.seed;
    scene = std::make_shared<const simulators::Scene>(simulators::make_skin_scene(scene_options));
  }

  simulators::CameraSimulatorOptions camera_options;
  camera_options.serial = args.camera_serial;
  camera_options.address = args.camera_address;
  camera_options.sensor_width = args.sensor_width;
  camera_options.sensor_height = args.sensor_height;
  camera_options.camera_model.seed = args.seed;
  camera_options.camera_model.sensitivity = sensitivity;
  simulators::LedControllerSimulator leds;
  const int modbus_port = leds.start_modbus_tcp(args.modbus_port);
  const std::string modbus_pty = leds.start_modbus_rtu();
  // The lab outlives the camera simulator (declared first): a non-owning pointer.
  const std::shared_ptr<const simulators::SphereIllumination> lab_light(std::shared_ptr<void>(), &leds.lab());
  simulators::CameraSimulator camera(camera_options, fixed_light ? fixed_light : lab_light, scene);
  camera.set_packet_loss_ratio(args.packet_loss);
  camera.set_exposure_hook([&leds] { leds.trigger(); });
  leds.lab().connect_trigger_output([&camera] { camera.pulse_trigger_input(); });  // the trigger master's output → Line0
  const auto led_info = leds.lab().info();

  std::cout << "camera: GigE Vision on " << camera.address() << ":"
            << simulators::CameraSimulator::kGvcpPort << " serial " << camera_options.serial << " (sensor "
            << camera_options.sensor_width << "x" << camera_options.sensor_height
            << ", Bayer RG / mono / RGB8 formats, packet loss " << args.packet_loss << ")\n";
  std::cout << "led controller: Modbus TCP on 127.0.0.1:" << modbus_port << " unit 1; Modbus RTU on "
            << modbus_pty << " unit 1 (model " << led_info.model << ", serial " << led_info.serial
            << "); trigger output wired to the camera's Line0, trigger input to its exposures\n";
  std::cout << "light: "
            << (fixed_light ? "fixed " + args.fixed_light + " spectrum (--fixed-light), not the LEDs"
                            : std::string("the LED lab (true LED spectra, drift, warm-up)"))
            << "\n";
  std::cout << "spectrometer, LED HID: in-process only (libusb / hidapi transport seams)\n";
  std::cout << "chromo-sim: running; Ctrl-C stops" << std::endl;

  int signal_number = 0;
  sigwait(&stop_signals, &signal_number);
  std::cout << "chromo-sim: " << (signal_number == SIGINT ? "SIGINT" : "SIGTERM") << ", stopping ("
            << camera.frames_rendered() << " camera frames rendered)" << std::endl;
  leds.lab().disconnect_trigger_outputs();  // before the camera goes
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"chromo-sim: the Chromosphere virtual lab (device simulators on their real protocols)"};
  SimArguments args;
  app.add_option("--camera-serial", args.camera_serial, "GigE Vision serial number of the camera simulator")
      ->capture_default_str();
  app.add_option("--sensor-width", args.sensor_width, "Sensor width, pixels")->check(CLI::Range(16, 4096))->capture_default_str();
  app.add_option("--sensor-height", args.sensor_height, "Sensor height, pixels")->check(CLI::Range(16, 4096))->capture_default_str();
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
  app.add_option("--camera-address", args.camera_address,
                 "Loopback address of the camera simulator, 127.a.b.c (default: a free one in 127.77.0.0/16)");
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
