// The spatial pass on one thread against the estimator's threads, side by
// side in one run (issue 39, next parts 1 and 2): its flags
// (refine_flags_with_neighbourhood: the per-pixel deviation, the per-block
// misfit eigen-solves and the per-pixel tests of every round) and its
// pooled-order refits (pool_model_order).
//
// Per plan (--plans, default `standard` and `multispectral`, the six LEDs'
// 18 channels) the lab session is rendered in process at the 5-MP sensor
// (--sensor W H, default 2448×2048: 1224×1024 cells, --seed), its tables
// prepared as chromod does and the per-pixel estimate made once; then, --repeats
// times in turn (one thread, then --threads, A B A B), the flags on copies
// of those estimates and the refits on copies of the flagged ones: wall and
// process CPU seconds of each and the busiest thread's CPU seconds (the
// wall time of an idle machine: on a loaded one the kernel's autogroups
// give a process the same share of the cores whatever its thread count),
// their ratios per pair, and whether one thread and all gave the same
// estimates bit for bit (exit 1 if not). Prints mean [min, max] over the
// pairs, writes DIR/spatial_threads.{csv,png} (--out, default bench/results).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <CLI/CLI.hpp>

#include "chart.hpp"
#include "clocks.hpp"
#include "guarded_main.hpp"
#include "seed_spread.hpp"
#include "chromo/estimation/spatial_flags.hpp"
#include "chromo/maps/estimate_report.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"

namespace chromo::bench {
namespace {

namespace fs = std::filesystem;
using estimation::PixelEstimate;

// Every field of every estimate equal bit for bit (NaN σ included).
bool same_bits(const std::vector<PixelEstimate>& a, const std::vector<PixelEstimate>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t p = 0; p < a.size(); ++p) {
    const PixelEstimate &x = a[p], &y = b[p];
    if (std::memcmp(&x.parameters, &y.parameters, sizeof x.parameters) || x.order != y.order || x.flag != y.flag ||
        std::memcmp(&x.residual, &y.residual, sizeof(float)) || std::memcmp(&x.chi2, &y.chi2, sizeof(float)) ||
        std::memcmp(&x.order_statistic, &y.order_statistic, sizeof(float)) ||
        std::memcmp(x.sigma, y.sigma, sizeof x.sigma) ||
        std::memcmp(&x.ch_che_correlation, &y.ch_che_correlation, sizeof(float)))
      return false;
  }
  return true;
}

// mean [min, max] of the values, printed with `format`.
std::string spread_text(const std::vector<double>& values, const char* format = "%.3f") {
  const Spread s = spread(values, [](double x) { return x; });
  char text[96], f[48];
  std::snprintf(f, sizeof f, "%s [%s, %s]", format, format, format);
  std::snprintf(text, sizeof text, f, s.mean, s.lo, s.hi);
  return text;
}

// CPU seconds each thread of this process has run (/proc/self/task/*/schedstat,
// nanoseconds), by thread id.
std::map<std::string, double> cpu_seconds_by_thread() {
  std::map<std::string, double> by_thread;
  for (const auto& task : fs::directory_iterator("/proc/self/task")) {
    std::ifstream in(task.path() / "schedstat");
    double ns = 0;
    if (in >> ns) by_thread[task.path().filename().string()] = ns * 1e-9;
  }
  return by_thread;
}

// The largest CPU time one thread spent between two readings: on an idle
// machine the call's wall time; on a loaded one (the kernel's autogroups
// share the cores per session, not per thread, so a second thread gains no
// wall time here) the figure that still shows the work being split.
double busiest_thread_s(const std::map<std::string, double>& before, const std::map<std::string, double>& after) {
  double busiest = 0;
  for (const auto& [thread, seconds] : after) {
    const auto b = before.find(thread);
    busiest = std::max(busiest, seconds - (b == before.end() ? 0.0 : b->second));
  }
  return busiest;
}

struct Timed {
  double wall_s = 0, cpu_s = 0, busiest_thread_s = 0;
  estimation::NeighbourhoodSummary summary;
  std::vector<PixelEstimate> estimates;
};

// One part of the pass (`part`: flags or refits) on a copy of `input`, timed.
enum class Part { kFlags, kRefits };
Timed run_part(Part part, const estimation::Estimator& estimator, const simulators::RenderedSession& lab,
               const std::vector<PixelEstimate>& input, const estimation::NeighbourhoodOptions& options) {
  Timed t;
  t.estimates = input;
  const auto start = std::chrono::steady_clock::now();
  const ElapsedClock<process_cpu_seconds> cpu;
  const auto threads_before = cpu_seconds_by_thread();
  const auto& m = lab.noisy;
  t.summary = part == Part::kFlags
                  ? estimation::refine_flags_with_neighbourhood(estimator, m.measured, m.width, m.height, t.estimates, options)
                  : estimation::pool_model_order(estimator, m.measured, m.width, m.height, t.estimates, options);
  t.wall_s = seconds_since(start);
  t.cpu_s = cpu.seconds();
  t.busiest_thread_s = busiest_thread_s(threads_before, cpu_seconds_by_thread());
  return t;
}

// The pairs of one part: figures per pair and their spread.
struct PartFigures {
  std::vector<double> one_wall, parallel_wall, ratio_wall, ratio_cpu, ratio_busiest;
  void add(const Timed& a, const Timed& b) {
    one_wall.push_back(a.wall_s), parallel_wall.push_back(b.wall_s);
    ratio_wall.push_back(a.wall_s / b.wall_s), ratio_cpu.push_back(a.cpu_s / b.cpu_s);
    ratio_busiest.push_back(a.busiest_thread_s / b.busiest_thread_s);
  }
  void print(const char* name) const {
    std::printf("  %s: wall s one thread %s, parallel %s; one thread / parallel: wall x%s, CPU x%s, busiest thread x%s\n",
                name, spread_text(one_wall).c_str(), spread_text(parallel_wall).c_str(),
                spread_text(ratio_wall, "%.2f").c_str(), spread_text(ratio_cpu, "%.2f").c_str(),
                spread_text(ratio_busiest, "%.2f").c_str());
  }
};

int bench_main(int argc, char** argv) {
  CLI::App app{"the spatial pass: one thread against the estimator's threads, side by side"};
  std::vector<std::string> plans{"standard", "multispectral"};
  std::vector<int> sensor{2448, 2048};
  std::uint64_t seed = 5;
  int repeats = 3, threads = 0;
  fs::path out = CHROMO_BENCH_RESULTS;
  app.add_option("--plans", plans, "built-in plans")->delimiter(',');
  app.add_option("--sensor", sensor, "sensor width and height")->expected(2);
  app.add_option("--seed", seed, "scene seed");
  app.add_option("--repeats", repeats, "pairs (one thread, then --threads)")->check(CLI::Range(1, 20));
  app.add_option("--threads", threads, "the parallel run's estimator threads (0: all cores)")->check(CLI::Range(0, 64));
  app.add_option("--out", out, "folder for spatial_threads.{csv,png}");
  CLI11_PARSE(app, argc, argv);

  fs::create_directories(out);
  std::ofstream csv(out / "spatial_threads.csv");
  csv << "plan,cells,part,pair,one_thread_wall_s,parallel_wall_s,one_thread_cpu_s,parallel_cpu_s,"
         "one_thread_busiest_thread_s,parallel_busiest_thread_s,same_bits\n";
  std::vector<Bar> bars;
  bool all_same = true;
  for (const std::string& plan : plans) {
    simulators::RenderedSessionOptions ro;
    ro.sensor_width = sensor[0], ro.sensor_height = sensor[1];
    ro.seed = seed, ro.threads = threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency()), ro.plan = plan;
    ro.noise_free = false;
    const simulators::RenderedSession lab = simulators::render_session(ro);
    maps::MethodEstimationOptions options;
    options.estimator.threads = threads;
    const maps::PreparedTables tables = maps::prepare_tables(lab.noisy.set, options);
    estimation::EstimatorOptions one = tables.estimator->options();
    one.threads = 1;
    const estimation::Estimator one_thread(tables.table, lab.noisy.set, one);
    const estimation::Estimator& parallel = *tables.estimator;
    std::vector<PixelEstimate> per_pixel(lab.pixels());
    parallel.estimate(lab.noisy.measured, per_pixel);
    std::printf("%s: %zu cells (%dx%d), %d channels, load average %.2f\n", plan.c_str(), lab.pixels(), lab.noisy.width,
                lab.noisy.height, parallel.channels(), load_average());
    PartFigures flags, refits;
    std::size_t refitted = 0, flagged_by_pass = 0;
    for (int pair = 0; pair < repeats; ++pair) {
      const Timed fa = run_part(Part::kFlags, one_thread, lab, per_pixel, options.neighbourhood);
      const Timed fb = run_part(Part::kFlags, parallel, lab, per_pixel, options.neighbourhood);
      const Timed ra = run_part(Part::kRefits, one_thread, lab, fa.estimates, options.neighbourhood);
      const Timed rb = run_part(Part::kRefits, parallel, lab, fa.estimates, options.neighbourhood);
      const bool same_flags = same_bits(fa.estimates, fb.estimates) &&
                              fa.summary.flagged_touching == fb.summary.flagged_touching &&
                              fa.summary.flagged_holes == fb.summary.flagged_holes;
      const bool same_refits = same_bits(ra.estimates, rb.estimates) && ra.summary.order_to_4 == rb.summary.order_to_4 &&
                               ra.summary.order_to_2 == rb.summary.order_to_2;
      all_same = all_same && same_flags && same_refits;
      flagged_by_pass = fa.summary.flagged_touching + fa.summary.flagged_holes;
      refitted = ra.summary.order_to_4 + ra.summary.order_to_2;
      flags.add(fa, fb), refits.add(ra, rb);
      for (const auto& [name, a, b, same] : {std::tuple{"flags", &fa, &fb, same_flags}, std::tuple{"refits", &ra, &rb, same_refits}}) {
        std::printf("  pair %d %s: one thread %.3f s wall (%.3f CPU, busiest thread %.3f), parallel %.3f s wall "
                    "(%.3f CPU, busiest thread %.3f): x%.2f wall, x%.2f busiest thread; %s\n",
                    pair + 1, name, a->wall_s, a->cpu_s, a->busiest_thread_s, b->wall_s, b->cpu_s, b->busiest_thread_s,
                    a->wall_s / b->wall_s, a->busiest_thread_s / b->busiest_thread_s,
                    same ? "same estimates bit for bit" : "ESTIMATES DIFFER");
        csv << plan << "," << lab.pixels() << "," << name << "," << pair + 1 << "," << a->wall_s << "," << b->wall_s
            << "," << a->cpu_s << "," << b->cpu_s << "," << a->busiest_thread_s << "," << b->busiest_thread_s << ","
            << same << "\n";
      }
    }
    std::printf("  flagged by the pass %zu, refitted %zu (pixels whose window changed their order)\n", flagged_by_pass,
                refitted);
    flags.print("flags");
    refits.print("refits");
    auto mean = [](const std::vector<double>& v) { return spread(v, [](double x) { return x; }).mean; };
    for (const auto& [name, f] : {std::pair{"flags", &flags}, std::pair{"refits", &refits}}) {
      bars.push_back({plan + " " + name + " one thread", mean(f->one_wall)});
      bars.push_back({plan + " " + name + " parallel", mean(f->parallel_wall)});
    }
  }
  std::printf("load average now %.2f; wrote %s\n", load_average(), (out / "spatial_threads.csv").c_str());
  write_bar_chart(out / "spatial_threads.png", "the spatial pass at 5 MP: one thread against all cores (wall s, mean of pairs)",
                  "wall seconds", bars);
  return all_same ? 0 : 1;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("spatial_threads_bench", chromo::bench::bench_main, argc, argv); }
