#pragma once
// The virtual-lab session every lab bench measures on: the standard session
// rendered from the lab's physics (simulators/scene/rendered_session.hpp), seed 5, on
// 2 threads, cached on disk in cache_dir (empty: not cached), so that
// estimation_bench renders it once and the others read it back.

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "chromo/simulators/scene/rendered_session.hpp"
#include "clocks.hpp"

namespace chromo::bench {

inline simulators::RenderedSessionOptions lab_session_options(int sensor_width, int sensor_height,
                                                          const std::filesystem::path& cache_dir) {
  simulators::RenderedSessionOptions ro;
  ro.sensor_width = sensor_width, ro.sensor_height = sensor_height, ro.seed = 5, ro.threads = 2;
  ro.cache_dir = cache_dir;
  return ro;
}

// Renders or loads the session and says which, and how long it took.
inline simulators::RenderedSession load_lab_session(const simulators::RenderedSessionOptions& ro) {
  const auto t = std::chrono::steady_clock::now();
  simulators::RenderedSession lab = simulators::render_session(ro);
  std::printf("virtual lab %dx%d -> %dx%d cells, %s in %.1f s\n", ro.sensor_width, ro.sensor_height, lab.width,
              lab.height, lab.loaded_from_cache ? "loaded from the cache" : "rendered", seconds_since(t));
  return lab;
}

}  // namespace chromo::bench
