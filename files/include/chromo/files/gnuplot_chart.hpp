#pragma once
// GnuplotChart: the one way the project draws a chart. Every PNG chart (the
// benchmarks' figures in bench/, `chromo leds plot`) is a gnuplot script run
// by gnuplot (Debian's gnuplot-nox, pngcairo terminal).
//
// It lives in files/ because a chart is one more file written for a person,
// beside its data, by any library or program, and it needs nothing of ours.
//
// draw_chart() composes the script as
//
//   set terminal <terminal>
//   set output '<png>'
//   <commands>
//
// writes it to `script_file` when one is given (so the chart can be redrawn
// with `gnuplot FILE` after editing), feeds it to gnuplot's standard input
// and waits for gnuplot. The data a script plots are the caller's files
// (CSV, written and closed before), or inline ('-' … e).
//
// Errors: never throws for gnuplot's sake; returns what went wrong (gnuplot
// missing, or its exit status) so that a benchmark can print its figures
// anyway and a command can fail with the message. Throws
// std::runtime_error naming the file when the script file cannot be written.

#include <filesystem>
#include <string>

namespace chromo::files {

struct GnuplotChart {
  std::filesystem::path png;
  std::string terminal = "pngcairo size 900,500";  // everything after "set terminal"
  std::string commands;                            // the script after "set output"
};

// "" when gnuplot drew the chart; otherwise "gnuplot ...: <why> (PNG)".
std::string draw_chart(const GnuplotChart& chart, const std::filesystem::path& script_file = {});

}  // namespace chromo::files
