// chromod: the Chromosphere control daemon. See docs/config.md.
//
//   chromod [--config FILE] [--socket PATH] [--sessions-dir DIR] [--tcp HOST:PORT] [--web HOST:PORT]
//   chromod [--config FILE] --write-host-files DIR   (udev rules and sysctl drop-in, then exit)
//
// Without --config it runs the built-in virtual lab. Prints one line
// "chromod: listening on unix:PATH" (and the TCP port) once it accepts calls;
// SIGINT/SIGTERM stop it cleanly (a running session is cancelled).
#include <malloc.h>

#include <csignal>
#include <iostream>
#include <thread>

#include <CLI/CLI.hpp>

#include "chromo/daemon/daemon.hpp"
#include "chromo/daemon/devices.hpp"
#include "chromo/daemon/host_files.hpp"
#include "chromo/daemon/log_line.hpp"
#include "chromo/daemon/server.hpp"
#include "chromo/daemon/web_server.hpp"
#include "chromo/files/binary_cache.hpp"

namespace {

// The daemon's own folder (socket, the virtual lab's run files): created
// owner-only when missing; an existing one is left as it is.
void create_runtime_dir(const std::filesystem::path& dir) {
  std::error_code error;
  if (std::filesystem::exists(dir, error)) return;
  std::filesystem::create_directories(dir, error);
  if (error) throw std::runtime_error("runtime_dir: cannot create " + dir.string() + " (" + error.message() + ")");
  std::filesystem::permissions(dir, std::filesystem::perms::owner_all, error);
}

}  // namespace

int main(int argc, char** argv) {
  // Every allocation of 256 KiB or more (frames, tables, maps) is its own
  // mapping, returned to the system when freed. glibc's default raises this
  // threshold as large blocks are freed, after which a session's tables and
  // frames stay in the heap arenas: the soak bench saw the resident size
  // climb ~60 MB a session to ~760 MB with nothing leaked
  // (bench/README.md, soak_bench).
  mallopt(M_MMAP_THRESHOLD, 256 * 1024);
  using namespace chromo::daemon;
  namespace files = chromo::files;
  CLI::App app{"chromod: the Chromosphere control daemon"};
  std::string config_file, socket, sessions_dir, tcp_address, web_address, host_files_root;
  app.add_option("--config", config_file, "configuration file (docs/config.md); none = the virtual lab");
  app.add_option("--socket", socket, "Unix socket path (overrides the configuration)");
  app.add_option("--sessions-dir", sessions_dir, "sessions folder (overrides the configuration)");
  app.add_option("--tcp", tcp_address, "TCP address host:port (overrides; needs a token in the configuration)");
  app.add_option("--web", web_address,
                 "serve the operator's web view on host:port (overrides web_address; needs a token, and TLS off loopback)");
  app.add_option("--write-host-files", host_files_root,
                 "write the udev rules and sysctl drop-in this configuration needs under DIR "
                 "(DIR/udev/rules.d/60-chromosphere.rules, DIR/sysctl.d/60-chromosphere.conf; /etc on a lab PC) and exit");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int status = app.exit(e);
    return status == 0 ? 0 : 2;  // --help is not an error; a bad command line is bad input
  }

  // Signals are taken by one thread with sigwait(); block them everywhere else.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  std::signal(SIGPIPE, SIG_IGN);

  try {
    // The whole configuration, with the command line's overrides, is checked
    // here (parse_config) before anything starts; a bad one exits 2 naming the key.
    nlohmann::json json = config_file.empty() ? nlohmann::json::object() : read_config_json(config_file);
    if (!socket.empty()) json["unix_socket"] = socket;
    if (!sessions_dir.empty()) json["sessions_dir"] = sessions_dir;
    if (!tcp_address.empty()) json["tcp_address"] = tcp_address;
    if (!web_address.empty()) json["web_address"] = web_address;
    DaemonConfig config = parse_config(json, config_file.empty() ? "configuration" : config_file);
    set_log_format(parse_log_format(config.log_format));
    if (!host_files_root.empty()) {
      for (const auto& path : write_host_files(config, host_files_root)) log_line(LogLevel::kInfo, "wrote " + path.string());
      return 0;
    }
    create_runtime_dir(config.runtime_dir);
    files::set_cache_limit_bytes(config.estimation.cache_limit_bytes);
    auto [devices, virtual_lab] = open_devices(config);
    if (!virtual_lab.empty())
      log_line(LogLevel::kInfo, "no devices configured: running the built-in virtual lab (" + virtual_lab + ")");
    for (auto& led : devices.led_controllers)
      if (!led->open_error.empty()) log_line(LogLevel::kError, led->config.name + ": " + led->open_error);
    for (auto& camera : devices.cameras)
      if (!camera->open_error.empty()) log_line(LogLevel::kError, camera->config.name + ": " + camera->open_error);
    for (auto& spectrometer : devices.spectrometers)
      if (!spectrometer->open_error.empty())
        log_line(LogLevel::kError, spectrometer->config.name + ": " + spectrometer->open_error);
    Daemon daemon(config, std::move(devices));
    Server server(daemon);
    if (!config.unix_socket.empty()) log_line(LogLevel::kInfo, "listening on unix:" + config.unix_socket);
    if (server.tcp_port() != 0)
      log_line(LogLevel::kInfo, "listening on tcp port " + std::to_string(server.tcp_port()) +
                                    (config.tls_certificate_file.empty() ? " (no TLS)" : " (TLS)"));
    std::unique_ptr<WebServer> web;
    if (!config.web_address.empty()) {
      if (config.web_dir.empty()) config.web_dir = CHROMO_DEFAULT_WEB_DIR;
      web = std::make_unique<WebServer>(config, server.in_process_channel(),
                                        [&server](const std::string& who, const std::string& action, const std::string& error) {
                                          server.audit(who, action, error);
                                        });
      log_line(LogLevel::kInfo, std::string("web view on ") + (config.tls_certificate_file.empty() ? "http" : "https") +
                                    "://" + config.web_address.substr(0, config.web_address.rfind(':')) + ":" +
                                    std::to_string(web->port()) + "/");
    }
    log_line(LogLevel::kInfo, "sessions in " + std::filesystem::absolute(config.sessions_dir).string());
    std::thread stopper([&] {
      int signal = 0;
      sigwait(&signals, &signal);
      log_line(LogLevel::kInfo, "signal " + std::to_string(signal) + ", stopping");
      server.shutdown();  // ends the API's streams, and with them the web view's event streams
      if (web) web->stop();
    });
    server.wait();
    stopper.join();
    return 0;
  } catch (const std::invalid_argument& error) {
    std::cerr << "chromod: configuration: " << error.what() << "\n";
    return 2;
  } catch (const std::exception& error) {
    log_line(LogLevel::kError, error.what());
    return 1;
  } catch (...) {  // no exception leaves main (issue 19)
    log_line(LogLevel::kError, "unknown exception");
    return 1;
  }
}
