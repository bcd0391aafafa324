// chromo: the Chromosphere operator command line. Exit statuses (README):
// 0 done, 1 an internal failure (message on stderr), 2 bad input (the command
// line or an input file; the message names the file and field), 3 a check of
// `chromo doctor` failed. No exception
// leaves main: a command's uncaught one is mapped here.
#include <iostream>

#include "chromo/files/bounded_read.hpp"
#include "chromo/spectral/table.hpp"
#include "commands.hpp"
#include "typo_suggestion.hpp"

int main(int argc, char** argv) {
  CLI::App app{"chromo: Chromosphere operator and offline tools"};
  app.require_subcommand(1);
  int exit_status = chromo::cli::kExitOk;
  chromo::cli::add_model_command(app, exit_status);
  chromo::cli::add_profiles_command(app, exit_status);
  chromo::cli::add_leds_command(app, exit_status);
  chromo::cli::add_fit_spectrum_command(app, exit_status);
  chromo::cli::add_discrepancy_command(app, exit_status);
  chromo::cli::add_real_skin_scene_command(app, exit_status);
  chromo::cli::add_estimate_command(app, exit_status);
  chromo::cli::add_relight_command(app, exit_status);
  chromo::cli::add_flush_command(app, exit_status);
  chromo::cli::add_import_maps_command(app, exit_status);
  chromo::cli::add_status_command(app, exit_status);
  chromo::cli::add_doctor_command(app, exit_status);
  chromo::cli::add_led_command(app, exit_status);
  chromo::cli::add_session_command(app, exit_status);
  chromo::cli::add_results_command(app, exit_status);
  chromo::cli::add_solve_command(app, exit_status);
  chromo::cli::add_plan_command(app, exit_status);
  chromo::cli::add_export_command(app, exit_status);
  chromo::cli::add_maps_command(app, exit_status);
  chromo::cli::add_study_command(app, exit_status);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    if (const std::string guess = chromo::cli::typo_suggestion(app, argc, argv); !guess.empty()) std::cerr << guess << "\n";
    return chromo::cli::kExitBadInput;
  } catch (const chromo::files::InputFileError& e) {  // a data file refused by the bounded reader (names the file)
    std::cerr << "chromo: " << e.what() << "\n";
    return chromo::cli::kExitBadInput;
  } catch (const chromo::spectral::DataError& e) {  // a CSV or LED library at fault (names the file and field)
    std::cerr << "chromo: " << e.what() << "\n";
    return chromo::cli::kExitBadInput;
  } catch (const std::invalid_argument& e) {  // the libraries' bad-input type
    std::cerr << "chromo: " << e.what() << "\n";
    return chromo::cli::kExitBadInput;
  } catch (const std::exception& e) {  // anything else escaping a command is ours: exit 1, never abort
    std::cerr << "chromo: internal error: " << e.what() << "\n";
    return chromo::cli::kExitFailure;
  } catch (...) {
    std::cerr << "chromo: internal error (unknown exception)\n";
    return chromo::cli::kExitFailure;
  }
  return exit_status;
}
