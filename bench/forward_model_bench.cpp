// Forward-model throughput: spectra per second and wavelength evaluations per
// second, one thread against two, and the closed-form multipole sum against
// the explicit term-by-term sum (MODEL.md's definition) per wavelength.
//
//   build/release/bin/forward_model_bench [google-benchmark flags]
//
// Prints the figures, the ratios (2 threads / 1 thread, closed form /
// explicit sum) and writes bench/results/forward_model.png.
//
// Target (issue "Foundation"): >= 1e7 wavelength evaluations/s per core,
// aim 5e7.
#include <stdexcept>
#include <iostream>
#include <benchmark/benchmark.h>

#include <cstdio>
#include <map>
#include <random>
#include <vector>

#include "guarded_main.hpp"
#include "chromo/estimation/layer_optics.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chart.hpp"

using namespace chromo::estimation;
using chromo::spectral::kGridSize;
using chromo::spectral::Spectrum;

namespace {

std::vector<SkinParameters> random_parameters(std::size_t n) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> cm(kCmRange.min, kCmRange.max), ch(kChRange.min, kChRange.max),
      bm(0.0, 1.0), che(0.0, kCheRange.max);
  std::vector<SkinParameters> p(n);
  for (auto& x : p) x = {cm(rng), ch(rng), bm(rng), che(rng)};
  return p;
}

void report(benchmark::State& state, std::size_t spectra) {
  const double n = static_cast<double>(spectra) * static_cast<double>(state.iterations());
  state.counters["spectra_per_s"] = benchmark::Counter(n, benchmark::Counter::kIsRate);
  state.counters["wavelengths_per_s"] = benchmark::Counter(n * kGridSize, benchmark::Counter::kIsRate);
}

void BM_SingleSpectrum(benchmark::State& state) {
  const SkinModel model;
  const auto params = random_parameters(1024);
  std::size_t i = 0;
  for (auto _ : state) {
    Spectrum s = model.albedo(params[i++ & 1023]);
    benchmark::DoNotOptimize(s);
  }
  report(state, 1);
}
BENCHMARK(BM_SingleSpectrum);

void BM_Batch(benchmark::State& state) {
  const SkinModel model;
  const auto params = random_parameters(100000);
  std::vector<Spectrum> out(params.size());
  for (auto _ : state) {
    model.albedo_batch(params, out, static_cast<int>(state.range(0)));
    benchmark::DoNotOptimize(out.data());
  }
  report(state, params.size());
}
BENCHMARK(BM_Batch)->Arg(1)->Arg(2)->ArgName("threads")->UseRealTime()->Unit(benchmark::kMillisecond);

// One wavelength through the scalar slab: the closed form against the
// explicit sum MODEL.md defines (N grown until a pair adds < 1e-9).
template <typename SlabFunction>
void run_slab(benchmark::State& state, SlabFunction slab) {
  const double a = boundary_coefficient(1.4);
  double sigma_a = 0.3;
  for (auto _ : state) {
    SlabReflectance r = slab(sigma_a, 8.0, 0.25, a, 1.0);
    benchmark::DoNotOptimize(r);
    sigma_a = sigma_a < 30 ? sigma_a * 1.01 : 0.3;
  }
  state.counters["slabs_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_SlabClosedForm(benchmark::State& state) { run_slab(state, multipole_slab); }
void BM_SlabExplicitSum(benchmark::State& state) {
  run_slab(state, [](double sa, double ss, double d, double a0, double ad) {
    return multipole_slab_explicit(sa, ss, d, a0, ad);
  });
}
BENCHMARK(BM_SlabClosedForm);
BENCHMARK(BM_SlabExplicitSum);

}  // namespace

// Keeps each run's counters so main() can form ratios and draw the chart.
class RecordingReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs)
      for (const auto& [name, counter] : run.counters) figures[run.benchmark_name()][name] = counter.value;
    ConsoleReporter::ReportRuns(runs);
  }
  std::map<std::string, std::map<std::string, double>> figures;
};

static int bench_main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  RecordingReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();

  auto& f = reporter.figures;
  const double single = f["BM_SingleSpectrum"]["wavelengths_per_s"];
  const double one = f["BM_Batch/threads:1/real_time"]["wavelengths_per_s"];
  const double two = f["BM_Batch/threads:2/real_time"]["wavelengths_per_s"];
  const double closed = f["BM_SlabClosedForm"]["slabs_per_s"];
  const double explicit_sum = f["BM_SlabExplicitSum"]["slabs_per_s"];
  if (one > 0 && two > 0) {
    std::printf("\nforward model: %.1f M wavelengths/s on 1 thread (%.2f us per spectrum), %.1f M on 2 threads\n",
                one / 1e6, 81e6 / one, two / 1e6);
    std::printf("  2 threads / 1 thread = %.2fx; target >= 10 M/s per core: %s; aim 50 M/s per core\n", two / one,
                one >= 1e7 ? "met" : "MISSED");
  }
  if (closed > 0 && explicit_sum > 0)
    std::printf("  multipole slab: closed form / explicit sum = %.2fx faster (scalar, one wavelength)\n",
                closed / explicit_sum);
  if (single > 0 && one > 0 && two > 0) {
    chromo::bench::write_bar_chart("bench/results/forward_model.png", "Skin forward model throughput (81-sample spectra)",
                                   "million wavelength evaluations / s",
                                   {{"single call", single / 1e6}, {"batch, 1 thread", one / 1e6},
                                    {"batch, 2 threads", two / 1e6}, {"target per core", 10.0}});
  }
  return 0;
}

int main(int argc, char** argv) { return chromo::bench::guarded_main("forward_model_bench", bench_main, argc, argv); }
