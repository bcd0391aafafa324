#pragma once
// Writes a bar or XY chart as PNG through gnuplot (Debian's gnuplot-nox).
// Benchmarks print their figures first; the chart is for people who would
// rather look than read. A missing gnuplot is reported, never fatal.

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace chromo::bench {

struct Bar {
  std::string label;
  double value;
};

// A horizontal-label bar chart of `bars` into `png_path`; the data and the
// gnuplot script are kept beside it (`.dat`, `.gp`) so the figure can be redrawn.
inline bool write_bar_chart(const std::filesystem::path& png_path, const std::string& title, const std::string& y_label,
                            const std::vector<Bar>& bars, bool log_scale = false) {
  std::filesystem::create_directories(png_path.parent_path());
  const auto data_path = std::filesystem::path(png_path).replace_extension(".dat");
  const auto script_path = std::filesystem::path(png_path).replace_extension(".gp");
  {
    std::ofstream data(data_path);
    for (const Bar& b : bars) data << '"' << b.label << "\" " << b.value << "\n";
    std::ofstream gp(script_path);
    gp << "set terminal pngcairo size 900,500 font 'DejaVu Sans,10'\n"
       << "set output '" << png_path.string() << "'\n"
       << "set title '" << title << "'\n"
       << "set ylabel '" << y_label << "'\n"
       << "set style fill solid 0.8 border -1\nset boxwidth 0.6\nset grid ytics\nset xtics rotate by -20\n"
       << "set yrange [0:*]\n" << (log_scale ? "set logscale y\nset yrange [*:*]\n" : "")
       << "plot '" << data_path.string() << "' using 0:2:xtic(1) with boxes notitle lc rgb '#4477aa', "
       << "'' using 0:2:(sprintf('%.3g', $2)) with labels offset 0,1 notitle\n";
  }
  const std::string command = "gnuplot '" + script_path.string() + "' 2>&1";
  if (std::system(command.c_str()) != 0) {
    std::fprintf(stderr, "chart: gnuplot failed or is missing; figures are in %s\n", data_path.c_str());
    return false;
  }
  return true;
}

}  // namespace chromo::bench
