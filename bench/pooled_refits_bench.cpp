// The spatial pass's pooled-order refits on one thread against the
// estimator's threads, side by side in one run (issue 39, next part 1).
//
// Per plan (--plans, default `standard` and `multispectral`, the six LEDs'
// 18 channels) the lab session is rendered in process at the 5-MP sensor
// (--sensor W H, default 2448×2048: 1224×1024 cells, --seed), its tables
// prepared as chromod does, the per-pixel estimate made once and the
// neighbourhood flags applied once (the pass runs flags first); then
// pool_model_order() on copies of those estimates, --repeats times in turn
// (one thread, then --threads, A B A B): wall and process CPU seconds of
// each and the busiest thread's CPU seconds (the wall time of an idle
// machine: on a loaded one the kernel's autogroups give a process the same
// share of the cores whatever its thread count), their ratios per pair, and whether the two gave the same estimates
// bit for bit; the flags' own time once for comparison. Prints mean
// [min, max] over the pairs, writes
// DIR/pooled_refits.{csv,png} (--out, default bench/results;
// pooled_refits_stored.{csv,png} with --stored-fits).
// --stored-fits: A is the refits and B the first pass's other-order fits
// (OtherOrderFit, no second inversion), both on --threads; the per-pixel
// pass is then timed once without and once with storing them.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "bench_cli.hpp"

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

Timed pool(const estimation::Estimator& estimator, const simulators::RenderedSession& lab,
           const std::vector<PixelEstimate>& flagged, const estimation::NeighbourhoodOptions& options,
           std::span<const estimation::OtherOrderFit> other = {}) {
  Timed t;
  t.estimates = flagged;
  const auto start = std::chrono::steady_clock::now();
  const ElapsedClock<process_cpu_seconds> cpu;
  const auto threads_before = cpu_seconds_by_thread();
  t.summary = estimation::pool_model_order(estimator, lab.noisy.measured, lab.noisy.width, lab.noisy.height,
                                           t.estimates, options, other);
  t.wall_s = seconds_since(start);
  t.cpu_s = cpu.seconds();
  t.busiest_thread_s = busiest_thread_s(threads_before, cpu_seconds_by_thread());
  return t;
}

int bench_main(int argc, char** argv) {
  CLI::App app{"pooled-order refits: one thread against the estimator's threads, side by side"};
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
  app.add_option("--out", out, "folder for pooled_refits.{csv,png}");
  bool stored_fits = false;
  app.add_flag("--stored-fits", stored_fits, "A: refits, B: the first pass's other-order fits, both on --threads");
  CLI11_PARSE(app, argc, argv);
  const char* a_name = stored_fits ? "refits" : "one thread";
  const char* b_name = stored_fits ? "stored fits" : "parallel";

  fs::create_directories(out);
  const std::string stem = stored_fits ? "pooled_refits_stored" : "pooled_refits";
  std::ofstream csv(out / (stem + ".csv"));
  const std::string a_key = stored_fits ? "refits" : "one_thread", b_key = stored_fits ? "stored_fits" : "parallel";
  csv << "plan,cells,refits,pair," << a_key << "_wall_s," << b_key << "_wall_s," << a_key << "_cpu_s," << b_key
      << "_cpu_s," << a_key << "_busiest_thread_s," << b_key << "_busiest_thread_s,same_bits\n";
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
    std::vector<PixelEstimate> flagged(lab.pixels());
    std::vector<estimation::OtherOrderFit> other(stored_fits ? lab.pixels() : 0);
    if (stored_fits) {  // the per-pixel pass without, then with, the other-order fits
      const ElapsedClock<process_cpu_seconds> without_cpu;
      parallel.estimate(lab.noisy.measured, flagged);
      const double without_s = without_cpu.seconds();
      const ElapsedClock<process_cpu_seconds> with_cpu;
      std::vector<PixelEstimate> with(lab.pixels());
      parallel.estimate(lab.noisy.measured, with, {}, {}, other);
      const double with_s = with_cpu.seconds();
      std::printf("%s: the per-pixel pass %.3f s CPU without storing the other-order fits, %.3f s with (x%.2f); "
                  "same estimates: %s\n", plan.c_str(), without_s, with_s, with_s / without_s,
                  same_bits(flagged, with) ? "yes" : "NO");
    } else {
      parallel.estimate(lab.noisy.measured, flagged);
    }
    const auto flags_start = std::chrono::steady_clock::now();
    const ElapsedClock<process_cpu_seconds> flags_cpu;
    estimation::refine_flags_with_neighbourhood(parallel, lab.noisy.measured, lab.noisy.width, lab.noisy.height,
                                                flagged, options.neighbourhood);
    std::printf("%s: %zu cells (%dx%d), %d channels, load average %.2f; the pass's flags (before the order, once) "
                "%.3f s wall, %.3f s CPU\n", plan.c_str(), lab.pixels(), lab.noisy.width, lab.noisy.height,
                parallel.channels(), load_average(), seconds_since(flags_start), flags_cpu.seconds());
    std::vector<double> one_wall, parallel_wall, ratio_wall, ratio_cpu, ratio_busiest;
    std::size_t refits = 0;
    for (int pair = 0; pair < repeats; ++pair) {
      const Timed a = pool(stored_fits ? parallel : one_thread, lab, flagged, options.neighbourhood);
      const Timed b = pool(parallel, lab, flagged, options.neighbourhood, other);
      const bool same = same_bits(a.estimates, b.estimates) && a.summary.order_to_4 == b.summary.order_to_4 &&
                        a.summary.order_to_2 == b.summary.order_to_2;
      all_same = all_same && same;
      refits = a.summary.order_to_4 + a.summary.order_to_2;
      one_wall.push_back(a.wall_s), parallel_wall.push_back(b.wall_s);
      ratio_wall.push_back(a.wall_s / b.wall_s), ratio_cpu.push_back(a.cpu_s / b.cpu_s);
      ratio_busiest.push_back(a.busiest_thread_s / b.busiest_thread_s);
      std::printf("  pair %d: %s %.3f s wall (%.3f CPU, busiest thread %.3f), %s %.3f s wall (%.3f CPU, "
                  "busiest thread %.3f): x%.2f wall, x%.2f busiest thread, x%.2f CPU; %s\n",
                  pair + 1, a_name, a.wall_s, a.cpu_s, a.busiest_thread_s, b_name, b.wall_s, b.cpu_s, b.busiest_thread_s,
                  a.wall_s / b.wall_s, a.busiest_thread_s / b.busiest_thread_s, a.cpu_s / b.cpu_s,
                  same ? "same estimates bit for bit" : "ESTIMATES DIFFER");
      csv << plan << "," << lab.pixels() << "," << refits << "," << pair + 1 << "," << a.wall_s << "," << b.wall_s << ","
          << a.cpu_s << "," << b.cpu_s << "," << a.busiest_thread_s << "," << b.busiest_thread_s << "," << same << "\n";
    }
    std::printf("  refits %zu (pixels whose window changed their order); wall s %s %s, %s %s; "
                "%s / %s: wall x%s, CPU x%s, busiest thread x%s; load average %.2f\n",
                refits, a_name, spread_text(one_wall).c_str(), b_name, spread_text(parallel_wall).c_str(), a_name,
                b_name, spread_text(ratio_wall, "%.2f").c_str(), spread_text(ratio_cpu, "%.2f").c_str(),
                spread_text(ratio_busiest, "%.2f").c_str(), load_average());
    auto mean = [](const std::vector<double>& v) { return spread(v, [](double x) { return x; }).mean; };
    bars.push_back({plan + " " + a_name, mean(one_wall)});
    bars.push_back({plan + " " + b_name, mean(parallel_wall)});
  }
  std::printf("load average now %.2f; wrote %s\n", load_average(), (out / (stem + ".csv")).c_str());
  write_bar_chart(out / (stem + ".png"),
                  stored_fits ? "pooled order at 5 MP: refits against the stored fits of the first pass (wall s, mean of pairs)"
                              : "pooled-order refits at 5 MP: one thread against all cores (wall s, mean of pairs)",
                  "wall seconds", bars);
  return all_same ? 0 : 1;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("pooled_refits_bench", chromo::bench::bench_main, argc, argv); }
