// chromod's configuration (docs/config.md): every key checked for type,
// range, readable files, usable folders and valid addresses before anything
// starts; and, as a process, chromod exits 2 naming the key before its
// virtual lab starts, never deleting a file it did not create (issue 19).
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "chromo/daemon/config.hpp"
#include "chromo/daemon/daemon.hpp"
#include "chromo/daemon/devices.hpp"
#include "chromo/daemon/internal/devices/virtual_lab.hpp"
#include "../support/fresh_directory.hpp"

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;

std::string refused(const nlohmann::json& json) {
  try {
    parse_config(json, "cfg");
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "accepted";
}

std::string text_of(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

struct ChromodRun {
  pid_t pid = 0;
  int exit_code = -1;
  std::string output;
};

// chromod with `arguments`, its output in directory/chromod.log; killed with
// SIGKILL (exit_code -1 then) after `seconds` if still running, or as soon as
// its log holds `kill_once_logged` when that is given.
ChromodRun run_chromod(const fs::path& directory, std::vector<std::string> arguments, int seconds = 20,
                       std::vector<std::string> environment = {}, const std::string& kill_once_logged = {}) {
  const std::string log = (directory / "chromod.log").string();
  fs::remove(log);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  arguments.insert(arguments.begin(), CHROMOD);
  std::vector<char*> argv;
  for (auto& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_strings(environment);
  for (char** e = environ; *e; ++e) env_strings.push_back(*e);
  std::vector<char*> envp;
  for (auto& e : env_strings) envp.push_back(e.data());
  envp.push_back(nullptr);
  pid_t pid = 0;
  EXPECT_EQ(posix_spawn(&pid, CHROMOD, &actions, nullptr, argv.data(), envp.data()), 0);
  posix_spawn_file_actions_destroy(&actions);
  ChromodRun run;
  run.pid = pid;
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    const bool logged = !kill_once_logged.empty() && text_of(log).find(kill_once_logged) != std::string::npos;
    if (logged || std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      run.output = text_of(log);
      return run;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  run.output = text_of(log);
  return run;
}

TEST(DaemonConfig, ParsesDevicesAndRefusesBadFieldsByName) {
  auto config = parse_config(nlohmann::json::parse(R"({
    "unix_socket": "/tmp/x.sock", "tcp_address": "127.0.0.1:7443", "token": "0123456789abcdef", "tcp_insecure": true,
    "devices": [{"name": "sphere", "kind": "led_controller", "backend": "modbus-tcp", "address": "127.0.0.1:1502"},
                {"name": "cam0", "kind": "camera", "backend": "aravis", "address": "SN123", "settings": {"gain_db": 3}}],
    "mixes": {"d65": {"W57": 0.5, "B": 0.2}}})"));
  ASSERT_EQ(config.devices.size(), 2u);
  EXPECT_EQ(config.devices[1].kind, DeviceKind::kCamera);
  EXPECT_EQ(config.devices[1].settings["gain_db"], 3);
  EXPECT_DOUBLE_EQ(config.mixes.at("d65")[5], 0.2);

  auto refused = [](const char* text) { return daemon::refused(nlohmann::json::parse(text)); };
  EXPECT_NE(refused(R"({"tcp_address": "0.0.0.0:1", "token": "short"})").find("token"), std::string::npos);
  // TCP is TLS unless the configuration says insecure, explicitly.
  EXPECT_NE(refused(R"({"tcp_address": "127.0.0.1:1", "token": "0123456789abcdef"})").find("tcp_insecure: TCP without TLS"),
            std::string::npos);
  EXPECT_NE(refused(R"({"tcp_address": "127.0.0.1:1", "token": "0123456789abcdef", "tcp_insecure": true,
                       "tls_certificate_file": "c.pem", "tls_private_key_file": "k.pem"})").find("tcp_insecure: true contradicts"),
            std::string::npos);
  EXPECT_NE(refused(R"({"tcp_address": "127.0.0.1:1", "tcp_insecure": true})").find("token: "), std::string::npos);
  EXPECT_NE(refused(R"({"tcp_insecure": "yes"})").find("tcp_insecure"), std::string::npos);
  EXPECT_NE(refused(R"({"max_streams": 0})").find("max_streams: 0 is outside [1, 1024]"), std::string::npos);
  EXPECT_EQ(parse_config(nlohmann::json::parse("{}")).max_streams, 64u);
  EXPECT_NE(refused(R"({"frame_attempts": "three"})").find("frame_attempts"), std::string::npos);
  // The web view's limits (issue 40), each refused naming the key.
  EXPECT_NE(refused(R"({"web_max_body_bytes": 100})").find("web_max_body_bytes: 100 is outside [1024, 67108864]"),
            std::string::npos);
  EXPECT_NE(refused(R"({"web_max_body_bytes": 1e12})").find("web_max_body_bytes"), std::string::npos);
  EXPECT_NE(refused(R"({"web_stream_keepalive_ms": 0})").find("web_stream_keepalive_ms: 0 is outside [100, 600000]"),
            std::string::npos);
  EXPECT_NE(refused(R"({"web_request_head_timeout_ms": 100})").find("web_request_head_timeout_ms: 100 is outside [500, 120000]"),
            std::string::npos);
  EXPECT_NE(refused(R"({"max_profile_exports": 0})").find("max_profile_exports: 0 is outside [1, 16]"), std::string::npos);
  EXPECT_NE(refused(R"({"tcp_handshake_timeout_ms": 50})").find("tcp_handshake_timeout_ms: 50 is outside [100, 120000]"),
            std::string::npos);
  EXPECT_EQ(parse_config(nlohmann::json::parse("{}")).tcp_handshake_timeout_ms, 10000u);
  EXPECT_NE(refused(R"({"web_max_streams": 41})").find("web_max_streams: 41 is outside [1, 40]"), std::string::npos);
  EXPECT_NE(refused(R"({"web_host_names": "chromo.lab"})").find("web_host_names: \"chromo.lab\" is not a JSON array"),
            std::string::npos);
  EXPECT_NE(refused(R"({"web_host_names": ["ok.example", "evil.example:80"]})").find("web_host_names[1]: "),
            std::string::npos);
  EXPECT_NE(refused(R"({"web_host_names": ["a b"]})").find("web_host_names[0]: "), std::string::npos);
  const auto defaults = parse_config(nlohmann::json::parse("{}"));
  EXPECT_EQ(defaults.web_max_body_bytes, 1u << 20);
  EXPECT_EQ(defaults.web_stream_keepalive_ms, 15000u);
  EXPECT_EQ(defaults.web_max_streams, 24u);
  EXPECT_TRUE(defaults.web_host_names.empty());
  EXPECT_EQ(parse_config(nlohmann::json::parse(R"({"web_host_names": ["chromo.lab.example", "[fd00::1]"]})")).web_host_names,
            (std::vector<std::string>{"chromo.lab.example", "[fd00::1]"}));
  EXPECT_NE(refused(R"({"colour": 1})").find("unknown key \"colour\""), std::string::npos);
  EXPECT_NE(refused(R"({"devices": [{"name": "a", "kind": "toaster", "backend": "x"}]})").find("devices[0].kind"),
            std::string::npos);
  EXPECT_NE(refused(R"({"mixes": {"d65": {"UV": 1}}})").find("mixes.d65.UV"), std::string::npos);
}


// The probes of issue 19, each refused naming its key.
TEST(DaemonConfig, RefusesEveryProbeOfIssue19NamingTheKey) {
  const std::string token = "0123456789abcdef";
  struct Probe {
    nlohmann::json json;
    std::string expected;
  };
  const std::vector<Probe> probes = {
      {{{"tcp_address", "127.0.0.1:99999"}, {"token", token}, {"tcp_insecure", true}}, "cfg: tcp_address: \"127.0.0.1:99999\": the port"},
      {{{"tcp_address", "127.0.0.1"}, {"token", token}, {"tcp_insecure", true}}, "cfg: tcp_address: \"127.0.0.1\" is not host:port"},
      {{{"tcp_address", "no-such-host.invalid:7443"}, {"token", token}, {"tcp_insecure", true}},
       "cfg: tcp_address: \"no-such-host.invalid:7443\": the host \"no-such-host.invalid\" is not a numeric"},
      {{{"storage_limit_bytes", -1}}, "cfg: storage_limit_bytes: -1 is outside"},
      {{{"storage_limit_bytes", 1.5}}, "cfg: storage_limit_bytes: 1.5 is not an integer"},
      {{{"frame_timeout_ms", -5}}, "cfg: frame_timeout_ms: -5 is outside [1, 600000]"},
      {{{"frame_timeout_ms", 0}}, "cfg: frame_timeout_ms: 0 is outside"},
      {{{"frame_attempts", 2.5}}, "cfg: frame_attempts: 2.5 is not an integer"},
      {{{"estimator_queue_frames", true}}, "cfg: estimator_queue_frames: true is not an integer"},
      {{{"estimation", {{"camera_sensitivity", "/no/such/camera.csv"}}}},
       "cfg: estimation.camera_sensitivity: /no/such/camera.csv: no such file"},
      {{{"estimation", {{"camera_sensitivity", "builtin:no_such_camera"}}}}, "cfg: estimation.camera_sensitivity: "},
      {{{"estimation", {{"threads", -1}}}}, "cfg: estimation.threads: -1 is outside [0, 256]"},
      {{{"estimation", {{"skin_denoise", "yes"}}}}, "cfg: estimation.skin_denoise: \"yes\" is not on or off"},
      {{{"estimation", {{"local_bias", "yes"}}}}, "cfg: estimation.local_bias: \"yes\" is not on or off"},
      {{{"estimation", {{"discrepancy_layer", "yes"}}}}, "cfg: estimation.discrepancy_layer: \"yes\" is not on or off"},
      {{{"estimation", {{"white_reflectance", 0}}}}, "cfg: estimation.white_reflectance: 0 is outside (0"},
      {{{"estimation", {{"cache_limit_bytes", 10}}}}, "cfg: estimation.cache_limit_bytes: 10 is outside"},
      {{{"estimation", {{"led_library", "/no/such/library.json"}}}},
       "cfg: estimation.led_library: /no/such/library.json: no such file"},
      {{{"estimation", {{"colour", 1}}}}, "cfg: estimation: unknown key \"colour\""},
      {{{"estimation", 3}}, "cfg: estimation: 3 is not a JSON object"},
      {{{"tcp_address", "127.0.0.1:0"}, {"token", token}, {"tls_certificate_file", "/no/cert.pem"},
        {"tls_private_key_file", "/no/key.pem"}},
       "cfg: tls_certificate_file: /no/cert.pem: no such file"},
      {{{"led_library", "/no/such/library.json"}}, "cfg: led_library: /no/such/library.json: no such file"},
      {{{"led_library", "/dev/zero"}}, "cfg: led_library: /dev/zero: not a regular file"},
      {{{"sessions_dir", "/proc/version/sessions"}}, "cfg: sessions_dir: /proc/version/sessions: cannot be created"},
      {{{"sessions_dir", "/proc/no-such-folder/sessions"}}, "cfg: sessions_dir: /proc/no-such-folder/sessions: cannot be created"},
      {{{"unix_socket_mode", "abc"}}, "cfg: unix_socket_mode: \"abc\" is not an octal file mode"},
      {{{"unix_socket_mode", "0999"}}, "cfg: unix_socket_mode: \"0999\" is not an octal file mode"},
      {{{"unix_socket_mode", "0044"}}, "cfg: unix_socket_mode: the owner must be able"},
      {{{"unix_socket", std::string(200, 'a')}}, "cfg: unix_socket: "},
      {{{"mixes", {{"d65", {{"W57", 1.5}}}}}}, "cfg: mixes.d65.W57: 1.5 is outside [0"},
      {{{"mixes", {{"d65", {{"W57", "high"}}}}}}, "cfg: mixes.d65.W57: \"high\" is not a number"},
      {{{"devices", {{{"name", "a"}, {"kind", "camera"}}}}}, "cfg: devices[0].backend: missing"},
      // Issue 20: capture and hazard keys.
      {{{"capture", {{"white_share", 0}}}}, "cfg: capture.white_share: 0 is outside (0.0, 1.0]"},
      {{{"capture", {{"white_share", 1.2}}}}, "cfg: capture.white_share: 1.2 is outside (0.0, 1.0]"},
      {{{"capture", {{"frames_per_capture", 0}}}}, "cfg: capture.frames_per_capture: 0 is outside [1, 1000]"},
      {{{"capture", {{"frames_per_capture", 100000}}}}, "cfg: capture.frames_per_capture: 100000 is outside [1, 1000]"},
      {{{"capture", {{"blue_ratio", -1}}}}, "cfg: capture.blue_ratio: -1 is outside [0.0, 100.0]"},
      {{{"capture", {{"exposure_per_capture", "yes"}}}}, "cfg: capture.exposure_per_capture: \"yes\" is not true or false"},
      {{{"capture", {{"subject_fill", 1.5}}}}, "cfg: capture.subject_fill: 1.5 is outside [0.0, 0.99]"},
      {{{"capture", {{"subject_fill", -0.1}}}}, "cfg: capture.subject_fill: -0.1 is outside [0.0, 0.99]"},
      {{{"capture", {{"subject_percentile", 0}}}}, "cfg: capture.subject_percentile: 0 is outside (0.0, 1.0]"},
      {{{"capture", {{"max_subject_exposure_ratio", 0.5}}}},
       "cfg: capture.max_subject_exposure_ratio: 0.5 is outside [1.0, 64.0]"},
      {{{"hazard", {{"w57_full_drive_irradiance_W_per_m2", -3}}}},
       "cfg: hazard.w57_full_drive_irradiance_W_per_m2: -3 is outside (0"},
      {{{"hazard", {{"limit_J_per_m2_sr", 0}}}}, "cfg: hazard.limit_J_per_m2_sr: 0 is outside (0"},
      {{{"hazard", {{"frame_allowance_ms", -1}}}}, "cfg: hazard.frame_allowance_ms: -1 is outside [0"},
      {{{"hazard", {{"limit", 1}}}}, "cfg: hazard: unknown key \"limit\""},
  };
  for (const auto& probe : probes) {
    const std::string error = refused(probe.json);
    EXPECT_EQ(error.rfind(probe.expected, 0), 0u) << probe.json.dump() << "\n  said: " << error;
  }
}

// "Keys added later follow the same rule": every key in the table refuses a
// value of the wrong type naming itself, and is documented in docs/config.md.
TEST(DaemonConfig, EveryKeyInTheTableRefusesAWrongTypeAndIsDocumented) {
  const std::string doc = text_of(fs::path(CHROMO_SOURCE_DIR) / "docs" / "config.md");
  const auto names = config_key_names();
  EXPECT_GE(names.size(), 23u);
  for (const auto& name : names) {
    nlohmann::json json = nlohmann::json::object();
    const auto dot = name.find('.');
    const nlohmann::json wrong = nlohmann::json::array({nlohmann::json::object()});  // [{}]: no key takes it
    if (dot == std::string::npos) json[name] = wrong;
    else json[name.substr(0, dot)][name.substr(dot + 1)] = wrong;
    const std::string error = refused(json);
    EXPECT_EQ(error.rfind("cfg: " + name, 0), 0u) << name << ": " << error;
    const std::string leaf = dot == std::string::npos ? name : name.substr(dot + 1);
    EXPECT_NE(doc.find("`" + leaf + "`"), std::string::npos) << name << " is not in docs/config.md";
  }
}

TEST(DaemonConfig, ChecksFilesByWhatTheyHold) {
  const auto dir = testing::fresh_directory("config-files");
  std::ofstream(dir / "not-pem.pem") << "hello\n";
  std::ofstream(dir / "library.json") << "{\"format\": 7}";
  std::ofstream(dir / "camera.csv") << "wavelength_nm,R,G,B\nx,y,z,w\n";
  const std::string token = "0123456789abcdef";
  EXPECT_NE(refused({{"tcp_address", "127.0.0.1:0"}, {"token", token}, {"tls_certificate_file", (dir / "not-pem.pem")},
                     {"tls_private_key_file", (dir / "not-pem.pem")}})
                .find("tls_certificate_file: " + (dir / "not-pem.pem").string() + ": not a PEM file"),
            std::string::npos);
  EXPECT_EQ(refused({{"led_library", dir / "library.json"}}).rfind("cfg: led_library: ", 0), 0u);
  EXPECT_EQ(refused({{"estimation", {{"camera_sensitivity", dir / "camera.csv"}}}})
                .rfind("cfg: estimation.camera_sensitivity: ", 0),
            0u);
  // A folder that does not exist yet but can be made is accepted, and left unmade.
  const auto config = parse_config({{"sessions_dir", dir / "a" / "b"}, {"runtime_dir", dir / "run"}}, "cfg");
  EXPECT_EQ(config.unix_socket, (dir / "run" / "chromod.sock").string());
  EXPECT_FALSE(fs::exists(dir / "a"));
  EXPECT_FALSE(fs::exists(dir / "run"));
  fs::remove_all(dir);
}

TEST(DaemonConfig, VirtualLabCamerasAreReadAndRefusedKeyByKey) {
  const DaemonConfig defaults = parse_config(nlohmann::json::object(), "cfg");
  ASSERT_EQ(defaults.virtual_lab.cameras.size(), 1u);
  EXPECT_EQ(defaults.virtual_lab.cameras[0].name, "cam0");
  const DaemonConfig two = parse_config(nlohmann::json::parse(R"({"virtual_lab": {"patch_width_mm": 60, "cameras": [
      {"name": "cam0"},
      {"name": "side", "sensor_width": 320, "sensor_height": 240, "pixel_format": "Mono12",
       "pose": {"distance_mm": 250, "azimuth_deg": 30, "focal_length_mm": 4}}]}})"),
                                        "cfg");
  ASSERT_EQ(two.virtual_lab.cameras.size(), 2u);
  EXPECT_EQ(two.virtual_lab.cameras[1].name, "side");
  EXPECT_EQ(two.virtual_lab.patch_width_mm, 60);
  EXPECT_EQ(refused({{"virtual_lab", {{"cameras", {{{"name", "a"}, {"sensor_height", 5000}}}}}}})
                .rfind("cfg: virtual_lab.cameras[0].sensor_height: 5000 is outside [16, 4096]", 0),
            0u);
  EXPECT_EQ(refused({{"virtual_lab", {{"cameras", nlohmann::json::array()}}}}),
            "cfg: virtual_lab.cameras: the lab needs at least one camera");
  EXPECT_EQ(refused({{"virtual_lab", {{"cameras", {{{"name", "sphere"}}}}}}}),
            "cfg: virtual_lab.cameras[0].name: \"sphere\" is the lab's LED controller or spectrometer");
  EXPECT_EQ(refused({{"virtual_lab", {{"cameras", {{{"name", "a"}, {"sensitivity", "/no/such.csv"}}}}}}}),
            "cfg: virtual_lab.cameras[0].sensitivity: /no/such.csv: no such file");
  // 30 mm away, swung 85 degrees: most of an 80 mm patch is behind the camera.
  EXPECT_EQ(refused({{"virtual_lab",
                      {{"cameras", {{{"name", "a"}, {"pose", {{"distance_mm", 30}, {"azimuth_deg", 85}}}}}}}}})
                .rfind("cfg: virtual_lab.cameras[0].pose: camera view: the patch is not wholly in front", 0),
            0u);
  EXPECT_EQ(refused({{"virtual_lab", {{"lenses", 1}}}}).rfind("cfg: virtual_lab: unknown key \"lenses\"", 0), 0u);
}

// The multi-pixel estimate (issue 37) is on by default, "off" is read, and a
// session's provenance records the setting the estimator runs with.
TEST(DaemonConfig, SkinDenoiseIsOnByDefaultAndRecordedInTheProvenance) {
  const DaemonConfig defaults = parse_config(nlohmann::json::object(), "cfg");
  EXPECT_EQ(defaults.estimation.skin_denoise, "on");
  EXPECT_EQ(parse_config(nlohmann::json::parse(R"({"estimation": {"skin_denoise": "off"}})"), "cfg").estimation.skin_denoise,
            "off");
  const fs::path directory = chromo::testing::fresh_directory("config_skin_denoise");
  for (const std::string setting : {"on", "off"}) {
    DaemonConfig config = defaults;
    config.sessions_dir = directory / setting;
    config.estimation.enabled = false;  // no estimator to prepare: the provenance alone
    config.estimation.skin_denoise = setting;
    const Daemon daemon(config, DeviceSet{});
    const auto options = daemon.session_provenance(session::SessionPlan{}, {}).estimator_options;
    ASSERT_EQ(options.count("skin_denoise"), 1u);
    EXPECT_EQ(options.at("skin_denoise"), setting);
  }
  fs::remove_all(directory);
}

TEST(DaemonConfig, DiscrepancyLayerIsReadOnByDefault) {
  EXPECT_EQ(parse_config(nlohmann::json::object(), "cfg").estimation.discrepancy_layer, "on");
  EXPECT_EQ(parse_config(nlohmann::json::parse(R"({"estimation": {"discrepancy_layer": "off"}})"), "cfg")
                .estimation.discrepancy_layer,
            "off");
}

// Subsurface spread in the lab's skin photographs (issue 37): off by default,
// read into the lab's scene options, a blue wider than the red refused.
TEST(DaemonConfig, VirtualLabSubsurfaceSpreadIsReadAndABadWidthRefused) {
  EXPECT_FALSE(virtual_lab_options(parse_config(nlohmann::json::object(), "cfg").virtual_lab).subsurface.on);
  const DaemonConfig on = parse_config(
      nlohmann::json::parse(R"({"virtual_lab": {"subsurface": true, "subsurface_blue_px": 1, "subsurface_red_px": 4}})"), "cfg");
  const VirtualLabOptions lab = virtual_lab_options(on.virtual_lab);
  EXPECT_TRUE(lab.subsurface.on);
  EXPECT_EQ(lab.subsurface.sigma_blue_px, 1);
  EXPECT_EQ(lab.subsurface.sigma_red_px, 4);
  EXPECT_EQ(refused({{"virtual_lab", {{"subsurface", true}, {"subsurface_blue_px", 5}}}}),
            "cfg: virtual_lab.subsurface_blue_px: must be in (0, subsurface_red_px], subsurface_red_px at most 64");
  EXPECT_EQ(refused({{"virtual_lab", {{"subsurface_red_px", 0}}}}).rfind("cfg: virtual_lab.subsurface_red_px: 0", 0), 0u);
}

TEST(DaemonConfig, PerCameraSensitivitiesAreReadAndEachFileChecked) {
  const DaemonConfig config = parse_config(
      nlohmann::json::parse(R"({"estimation": {"camera_sensitivities": {"side": "builtin:canon_eos_5d_mark_ii"}}})"),
      "cfg");
  ASSERT_EQ(config.estimation.camera_sensitivities.size(), 1u);
  EXPECT_EQ(config.estimation.camera_sensitivities.at("side"), "builtin:canon_eos_5d_mark_ii");
  EXPECT_TRUE(parse_config(nlohmann::json::object(), "cfg").estimation.camera_sensitivities.empty());
  EXPECT_EQ(refused({{"estimation", {{"camera_sensitivities", {{"side", "/no/such.csv"}}}}}}),
            "cfg: estimation.camera_sensitivities[\"side\"]: /no/such.csv: no such file");
  EXPECT_EQ(refused({{"estimation", {{"camera_sensitivities", {{"side", 5}}}}}})
                .rfind("cfg: estimation.camera_sensitivities[\"side\"]: 5 is not a string", 0),
            0u);
  EXPECT_EQ(refused({{"estimation", {{"camera_sensitivities", "builtin:nikon_d5100"}}}})
                .rfind("cfg: estimation.camera_sensitivities: ", 0),
            0u);
}

// The maps' scale for a configured sphere's cameras (docs/maps.md "Scale
// bar"): read per camera, each width checked, and kept over the virtual lab's.
TEST(DaemonConfig, PerCameraFieldWidthsAreReadCheckedAndOverrideTheLabs) {
  DaemonConfig config = parse_config(nlohmann::json::parse(R"({"estimation": {"camera_field_width_mm": {"cam0": 123.5}}})"), "cfg");
  ASSERT_EQ(config.estimation.camera_field_width_mm.size(), 1u);
  EXPECT_EQ(config.estimation.camera_field_width_mm.at("cam0"), 123.5);
  for (const auto& bad : {nlohmann::json(0), nlohmann::json(-3), nlohmann::json(1e308), nlohmann::json("80"), nlohmann::json(nullptr)})
    EXPECT_EQ(refused({{"estimation", {{"camera_field_width_mm", {{"cam0", bad}}}}}})
                  .rfind("cfg: estimation.camera_field_width_mm[\"cam0\"]: " + bad.dump() + " is not a width in (0, 10000] mm", 0),
              0u) << bad.dump();
  EXPECT_EQ(refused({{"estimation", {{"camera_field_width_mm", 80}}}}).rfind("cfg: estimation.camera_field_width_mm: 80 is not a JSON object", 0),
            0u);
  {  // The virtual lab's cam0 (no pose: its 80 mm patch fills the rows) keeps the configured width.
    const OpenedDevices opened = open_devices(config);
    EXPECT_EQ(config.estimation.camera_field_width_mm.at("cam0"), 123.5);
  }
  DaemonConfig unconfigured = parse_config(nlohmann::json::object(), "cfg");
  const OpenedDevices opened = open_devices(unconfigured);
  EXPECT_EQ(unconfigured.estimation.camera_field_width_mm.at("cam0"), 80.0);
}

TEST(DaemonConfig, TheDefaultSocketAndRunFilesAreNotUnderTmp) {
  const DaemonConfig config;
  EXPECT_FALSE(config.runtime_dir.empty());
  EXPECT_NE(config.unix_socket.rfind("/tmp/", 0), 0u) << config.unix_socket;
  EXPECT_EQ(config.unix_socket, (config.runtime_dir / "chromod.sock").string());
  EXPECT_EQ(config.estimation.cache_limit_bytes, 2ull << 30);
}

// A JSON built in C++ (not parsed) holds 2000 as a signed integer.
TEST(DaemonConfig, IntegersBuiltInCodeAreReadByValue) {
  nlohmann::json json;
  json["frame_timeout_ms"] = static_cast<int>(2000);
  json["storage_limit_bytes"] = static_cast<long long>(5);
  const auto config = parse_config(json, "cfg");
  EXPECT_EQ(config.frame_timeout_ms, 2000u);
  EXPECT_EQ(config.storage_limit_bytes, 5u);
  json["frame_timeout_ms"] = static_cast<int>(-2000);
  EXPECT_EQ(refused(json).rfind("cfg: frame_timeout_ms: -2000 is outside", 0), 0u);
}

// As a process: a bad configuration exits 2 naming the key, and the virtual
// lab never started (it prints a line when it does).
TEST(Chromod, ABadConfigurationExitsTwoBeforeTheLabStarts) {
  const auto dir = testing::fresh_directory("chromod-config");
  const std::string token = "0123456789abcdef0";
  const std::vector<std::pair<nlohmann::json, std::string>> probes = {
      {{{"tcp_address", "256.1.1.1:7443"}, {"token", token}, {"tcp_insecure", true}}, "tcp_address: "},
      {{{"tcp_address", "127.0.0.1:0"}, {"token", token}, {"tls_certificate_file", "/no/cert.pem"},
        {"tls_private_key_file", "/no/key.pem"}},
       "tls_certificate_file: "},
      {{{"sessions_dir", "/proc/version/x"}}, "sessions_dir: "},
      {{{"led_library", (dir / "missing.json").string()}}, "led_library: "},
      {{{"unix_socket_mode", "abc"}}, "unix_socket_mode: "},
      {{{"storage_limit_bytes", -1}}, "storage_limit_bytes: "},
  };
  for (const auto& [json, key] : probes) {
    std::ofstream(dir / "config.json") << json.dump();
    const ChromodRun run = run_chromod(dir, {"--config", (dir / "config.json").string(), "--socket", (dir / "s.sock").string()});
    EXPECT_EQ(run.exit_code, 2) << json.dump() << "\n" << run.output;
    EXPECT_NE(run.output.find("chromod: configuration: " + (dir / "config.json").string() + ": " + key),
              std::string::npos)
        << run.output;
    EXPECT_EQ(run.output.find("virtual lab"), std::string::npos) << run.output;
  }
  fs::remove_all(dir);
}

// unix_socket used to delete whatever file was at its path.
TEST(Chromod, NeverDeletesAFileAtItsSocketPath) {
  const auto dir = testing::fresh_directory("chromod-socket");
  std::ofstream(dir / "precious.txt") << "keep me\n";
  const ChromodRun run = run_chromod(dir, {"--socket", (dir / "precious.txt").string(), "--sessions-dir", (dir / "s").string()});
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("unix_socket: " + (dir / "precious.txt").string() + ": a file that is not a socket"),
            std::string::npos)
      << run.output;
  EXPECT_EQ(text_of(dir / "precious.txt"), "keep me\n");
  EXPECT_FALSE(fs::exists(dir / "s"));  // nothing made either
  fs::remove_all(dir);
}

// A killed chromod left its camera XML in /tmp; now its run files live in
// its runtime folder, and the XML only while the camera simulator starts.
// A socket left by the killed chromod is replaced by the next one.
TEST(Chromod, AKilledDaemonLeavesNoRunFileButItsSocketWhichTheNextReplaces) {
  const auto dir = testing::fresh_directory("chromod-run");
  const fs::path run_dir = dir / "run";
  const std::vector<std::string> env{"CHROMO_RUNTIME_DIR=" + run_dir.string()};
  for (int round = 0; round < 2; ++round) {
    // Killed once listening (the lab starts in a few seconds), at the latest after 60 s.
    const std::string listening = "listening on unix:" + (run_dir / "chromod.sock").string();
    const ChromodRun run = run_chromod(dir, {"--sessions-dir", (dir / "sessions").string()}, 60, env, listening);
    EXPECT_EQ(run.exit_code, -1) << run.output;
    EXPECT_NE(run.output.find(listening), std::string::npos) << run.output;
    std::vector<std::string> left;
    for (const auto& entry : fs::directory_iterator(run_dir)) left.push_back(entry.path().filename().string());
    EXPECT_EQ(left, std::vector<std::string>{"chromod.sock"});
    EXPECT_EQ(fs::status(run_dir).permissions() & fs::perms::all, fs::perms::owner_all);
    EXPECT_FALSE(fs::exists(fs::temp_directory_path() /
                            ("chromo-camera-sim-" + std::to_string(run.pid) + "-CHROMO-VLAB-CAM.xml")));
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace chromo::daemon
