#pragma once
// estimate_stages_bench --exr-levels MAPS.exr (issue 39, speed39b part 3):
// one stored maps.exr written again at OpenEXR's default ZIP level (4, A)
// and at each other level asked for (B), in turn (A B A B ...), the file's
// size and the write's wall and process CPU seconds per pair, the B/A
// ratios as mean [min, max]; every written file is read back and compared
// with the stored one channel by channel (lossless at every level).

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include "clocks.hpp"
#include "chromo/files/float_image.hpp"

namespace chromo::bench {

struct ExrWrite {
  double wall_s = 0, cpu_s = 0;
  std::uintmax_t bytes = 0;
};

// One write of image at zip_level on `threads` threads; the file read back must equal image.
inline ExrWrite timed_exr_write(const files::FloatImage& image, const std::filesystem::path& file, int zip_level,
                                int threads) {
  ExrWrite w;
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  files::write_exr(file, image, {threads, zip_level});
  w.wall_s = seconds_since(t0), w.cpu_s = process_cpu_seconds() - cpu0;
  w.bytes = std::filesystem::file_size(file);
  const files::FloatImage back = files::read_exr(file);
  if (back.channel_names != image.channel_names) throw std::runtime_error("EXR level " + std::to_string(zip_level) + ": channels differ");
  for (std::size_t c = 0; c < image.channels.size(); ++c)
    if (std::memcmp(back.channels[c].data(), image.channels[c].data(), image.channels[c].size() * sizeof(float)) != 0)
      throw std::runtime_error("EXR level " + std::to_string(zip_level) + ": channel " + image.channel_names[c] + " differs");
  return w;
}

inline int exr_level_pairs_main(const std::filesystem::path& maps_file, const std::vector<int>& levels, int pairs,
                                int threads) {
  const files::FloatImage image = files::read_exr(maps_file);
  const std::filesystem::path scratch =
      std::filesystem::temp_directory_path() / ("exr_level_pairs-" + std::to_string(::getpid()) + ".exr");
  std::printf("estimate_stages_bench --exr-levels %s: %dx%d, %zu channels, %d writer threads, %d pairs; load %.2f\n",
              maps_file.c_str(), image.width, image.height, image.channels.size(), threads, pairs, load_average());
  std::printf("pair  level  wall_s  cpu_s  MB     (A = level 4, OpenEXR's default)\n");
  for (const int level : levels) {
    std::vector<double> wall, cpu, size;
    for (int p = 1; p <= pairs; ++p) {
      const ExrWrite a = timed_exr_write(image, scratch, 4, threads);
      const ExrWrite b = timed_exr_write(image, scratch, level, threads);
      std::printf("%4d  A 4    %6.3f  %5.3f  %6.2f\n%4d  B %-4d %6.3f  %5.3f  %6.2f   load %.2f\n", p, a.wall_s, a.cpu_s,
                  a.bytes / 1e6, p, level, b.wall_s, b.cpu_s, b.bytes / 1e6, load_average());
      wall.push_back(b.wall_s / a.wall_s), cpu.push_back(b.cpu_s / a.cpu_s),
          size.push_back(static_cast<double>(b.bytes) / static_cast<double>(a.bytes));
    }
    auto spread = [](const std::vector<double>& v) {
      double sum = 0, lo = v.front(), hi = v.front();
      for (double x : v) sum += x, lo = std::min(lo, x), hi = std::max(hi, x);
      char text[96];
      std::snprintf(text, sizeof text, "x%.3f [%.3f, %.3f]", sum / v.size(), lo, hi);
      return std::string(text);
    };
    std::printf("level %d / level 4: wall %s, CPU %s, size %s; read back equal to the stored maps at both\n", level,
                spread(wall).c_str(), spread(cpu).c_str(), spread(size).c_str());
  }
  std::filesystem::remove(scratch);
  return 0;
}

}  // namespace chromo::bench
