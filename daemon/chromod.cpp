// chromod: the Chromosphere control daemon. See docs/config.md.
//
//   chromod [--config FILE] [--socket PATH] [--sessions-dir DIR]
//
// Without --config it runs the built-in virtual lab. Prints one line
// "chromod: listening on unix:PATH" (and the TCP port) once it accepts calls;
// SIGINT/SIGTERM stop it cleanly (a running session is cancelled).
#include <csignal>
#include <iostream>
#include <thread>

#include <CLI/CLI.hpp>

#include "chromo/daemon/daemon.hpp"
#include "chromo/daemon/server.hpp"
#include "chromo/daemon/virtual_lab.hpp"

int main(int argc, char** argv) {
  using namespace chromo::daemon;
  CLI::App app{"chromod: the Chromosphere control daemon"};
  std::string config_file, socket, sessions_dir, tcp_address;
  app.add_option("--config", config_file, "configuration file (docs/config.md); none = the virtual lab");
  app.add_option("--socket", socket, "Unix socket path (overrides the configuration)");
  app.add_option("--sessions-dir", sessions_dir, "sessions folder (overrides the configuration)");
  app.add_option("--tcp", tcp_address, "TCP address host:port (overrides; needs a token in the configuration)");
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
    DaemonConfig config = config_file.empty() ? DaemonConfig{} : read_config_file(config_file);
    if (!socket.empty()) config.unix_socket = socket;
    if (!sessions_dir.empty()) config.sessions_dir = sessions_dir;
    if (!tcp_address.empty()) config.tcp_address = tcp_address;
    std::string error;
    if (!config.IsValid(&error)) throw std::invalid_argument(error);
    DeviceSet devices;
    if (config.devices.empty()) {
      auto lab = start_virtual_lab();
      config.devices = lab.devices;
      if (config.mixes.empty()) config.mixes = lab.mixes;
      std::cout << "chromod: no devices configured: running the built-in virtual lab (" << lab.description << ")\n";
      devices = std::move(lab.device_set);
    } else {
      devices = builtin_backends().open(config.devices);
    }
    for (auto& led : devices.led_controllers)
      if (!led->open_error.empty()) std::cerr << "chromod: " << led->config.name << ": " << led->open_error << "\n";
    for (auto& camera : devices.cameras)
      if (!camera->open_error.empty()) std::cerr << "chromod: " << camera->config.name << ": " << camera->open_error << "\n";
    for (auto& spectrometer : devices.spectrometers)
      if (!spectrometer->open_error.empty())
        std::cerr << "chromod: " << spectrometer->config.name << ": " << spectrometer->open_error << "\n";
    Daemon daemon(config, std::move(devices));
    Server server(daemon);
    if (!config.unix_socket.empty()) std::cout << "chromod: listening on unix:" << config.unix_socket << "\n";
    if (server.tcp_port() != 0)
      std::cout << "chromod: listening on tcp port " << server.tcp_port()
                << (config.tls_certificate_file.empty() ? " (no TLS)" : " (TLS)") << "\n";
    std::cout << "chromod: sessions in " << std::filesystem::absolute(config.sessions_dir).string() << std::endl;
    std::thread stopper([&] {
      int signal = 0;
      sigwait(&signals, &signal);
      std::cout << "chromod: signal " << signal << ", stopping" << std::endl;
      server.shutdown();
    });
    server.wait();
    stopper.join();
    return 0;
  } catch (const std::invalid_argument& error) {
    std::cerr << "chromod: configuration: " << error.what() << "\n";
    return 2;
  } catch (const std::exception& error) {
    std::cerr << "chromod: " << error.what() << "\n";
    return 1;
  } catch (...) {  // no exception leaves main (issue 19)
    std::cerr << "chromod: unknown exception\n";
    return 1;
  }
}
