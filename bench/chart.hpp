#pragma once
// A bar chart as PNG through the project's chart helper
// (files/gnuplot_chart.hpp). Benchmarks print their figures first; the chart
// is for people who would rather look than read. A missing gnuplot is
// reported, never fatal.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "chromo/files/gnuplot_chart.hpp"

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
  }
  files::GnuplotChart chart;
  chart.png = png_path;
  chart.terminal = "pngcairo size 900,500 font 'DejaVu Sans,10'";
  chart.commands = "set title '" + title + "'\n" +
                   "set ylabel '" + y_label + "'\n"
                   "set style fill solid 0.8 border -1\nset boxwidth 0.6\nset grid ytics\nset xtics rotate by -20\n"
                   "set yrange [0:*]\n" + (log_scale ? "set logscale y\nset yrange [*:*]\n" : "") +
                   "plot '" + data_path.string() + "' using 0:2:xtic(1) with boxes notitle lc rgb '#4477aa', "
                   "'' using 0:2:(sprintf('%.3g', $2)) with labels offset 0,1 notitle\n";
  if (const std::string failed = files::draw_chart(chart, script_path); !failed.empty()) {
    std::fprintf(stderr, "chart: %s; figures are in %s\n", failed.c_str(), data_path.c_str());
    return false;
  }
  return true;
}

struct LineSeries {
  std::string title;
  std::vector<std::pair<double, double>> points;  // (x, y)
};

// A line chart (points joined) of several series into `png_path`, the data and
// script kept beside it as write_bar_chart does.
inline bool write_line_chart(const std::filesystem::path& png_path, const std::string& title, const std::string& x_label,
                             const std::string& y_label, const std::vector<LineSeries>& series, bool log_x = false) {
  std::filesystem::create_directories(png_path.parent_path());
  const auto data_path = std::filesystem::path(png_path).replace_extension(".dat");
  const auto script_path = std::filesystem::path(png_path).replace_extension(".gp");
  std::string plot = "plot ";
  {
    std::ofstream data(data_path);
    for (std::size_t s = 0; s < series.size(); ++s) {
      data << "# " << series[s].title << "\n";
      for (const auto& [x, y] : series[s].points) data << x << " " << y << "\n";
      data << "\n\n";
      plot += (s ? ", '" : "'") + data_path.string() + "' index " + std::to_string(s) + " using 1:2 with linespoints lw 2 title '" +
              series[s].title + "'";
    }
  }
  files::GnuplotChart chart;
  chart.png = png_path;
  chart.terminal = "pngcairo size 900,500 font 'DejaVu Sans,10'";
  chart.commands = "set title '" + title + "'\nset xlabel '" + x_label + "'\nset ylabel '" + y_label +
                   "'\nset grid\nset key outside right\n" + (log_x ? "set logscale x 2\n" : "") + plot + "\n";
  if (const std::string failed = files::draw_chart(chart, script_path); !failed.empty()) {
    std::fprintf(stderr, "chart: %s; figures are in %s\n", failed.c_str(), data_path.c_str());
    return false;
  }
  return true;
}

}  // namespace chromo::bench
