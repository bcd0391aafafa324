// chromo: the Chromosphere operator command line.
#include <iostream>

#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"chromo: Chromosphere operator and offline tools"};
  app.require_subcommand(1);
  int exit_status = chromo::cli::kExitOk;
  chromo::cli::add_model_command(app, exit_status);
  chromo::cli::add_profiles_command(app, exit_status);
  chromo::cli::add_leds_command(app, exit_status);
  chromo::cli::add_fit_spectrum_command(app, exit_status);
  chromo::cli::add_estimate_command(app, exit_status);
  chromo::cli::add_relight_command(app, exit_status);
  chromo::cli::add_flush_command(app, exit_status);
  chromo::cli::add_import_maps_command(app, exit_status);
  chromo::cli::add_status_command(app, exit_status);
  chromo::cli::add_led_command(app, exit_status);
  chromo::cli::add_session_command(app, exit_status);
  chromo::cli::add_results_command(app, exit_status);
  chromo::cli::add_solve_command(app, exit_status);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return chromo::cli::kExitBadInput;
  }
  return exit_status;
}
