#pragma once
// Each subcommand registers itself on the app and returns the exit status
// through the callback slot it is given.

#include <CLI/CLI.hpp>

namespace chromo::cli {

// Exit statuses shared by every command.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;     // something went wrong inside
inline constexpr int kExitBadInput = 2;    // the command line or an input file was wrong
inline constexpr int kExitCheckFailed = 3; // chromo doctor: a check of the lab failed

void add_model_command(CLI::App& app, int& exit_status);
void add_profiles_command(CLI::App& app, int& exit_status);
void add_leds_command(CLI::App& app, int& exit_status);
void add_fit_spectrum_command(CLI::App& app, int& exit_status);
void add_discrepancy_command(CLI::App& app, int& exit_status);
void add_real_skin_scene_command(CLI::App& app, int& exit_status);
void add_estimate_command(CLI::App& app, int& exit_status);
// What the maps are for (docs/maps.md); import-maps also registers make-maps-test-data.
void add_relight_command(CLI::App& app, int& exit_status);
void add_flush_command(CLI::App& app, int& exit_status);
void add_import_maps_command(CLI::App& app, int& exit_status);
// Runs a map operation: std::invalid_argument → kExitBadInput, other errors → kExitFailure (message on stderr).
int run_map_operation(const char* command, const std::function<void()>& operation);
// `chromo leds measure`, under the `leds` subcommand (leds_measure.cpp).
void add_leds_measure_command(CLI::App* leds, int& exit_status);
// Operator commands talking to chromod (daemon_client.hpp).
void add_status_command(CLI::App& app, int& exit_status);
// The lab's checks through chromod (doctor_command.cpp, docs/doctor.md).
void add_doctor_command(CLI::App& app, int& exit_status);
void add_led_command(CLI::App& app, int& exit_status);
void add_session_command(CLI::App& app, int& exit_status);
void add_results_command(CLI::App& app, int& exit_status);
void add_solve_command(CLI::App& app, int& exit_status);
// A stored session's maps and frames as OME-TIFF (export_command.cpp).
void add_export_command(CLI::App& app, int& exit_status);
// `chromo maps stats`: region statistics from a stored session's maps.exr (maps_stats_command.cpp).
void add_maps_command(CLI::App& app, int& exit_status);
// `chromo maps compare`: two sessions before/after (maps_compare_command.cpp).
void add_maps_compare_command(CLI::App* maps_command, int& exit_status);
// The plan advisor offline (plan_command.cpp).
void add_plan_command(CLI::App& app, int& exit_status);
// A study of many stored sessions, here or on a Slurm cluster (study_command.cpp).
void add_study_command(CLI::App& app, int& exit_status);

}  // namespace chromo::cli
