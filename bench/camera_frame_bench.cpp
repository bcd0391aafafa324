// camera_frame_bench: the virtual lab's camera readout (CameraModel, shot,
// read and quantisation noise per site) on one 5-MP frame, before and after
// the band streams of issue 21 part 5, side by side in one run.
//
//   camera_frame_bench [--sensor W H] [--repeats N] [--threads N] [--out DIR] [--no-chart]
//
// The frames: a lit one (a BayerRG12 window whose response runs from 0 to
// 1.2 × the full well across the sensor at 10 ms: dark corners on the exact
// Poisson path, most sites on the normal approximation, a saturated edge)
// and a dark capture's (no light: every site on the exact Poisson path at
// mean 0). Each read out `repeats` times by
//   single stream  CameraModel::expose_single_stream: one std::mt19937_64
//                  over the frame, std::normal_distribution and
//                  std::poisson_distribution, one thread (the code before);
//   bands          CameraModel::expose: xoshiro256+ per band of 32 rows,
//                  ziggurat normals, exact Poisson by inversion, bands on
//                  `threads` OpenMP threads (default: OpenMP's, the machine's
//                  cores), and on one thread.
// Printed per frame and readout: CPU (the process, all threads) and wall
// milliseconds per frame (the best of the repeats, less disturbed by the
// machine's other work), the ratios single stream / bands, and the noise of
// each readout against the model's stated figures: mean of (DN − expected)
// and the RMS of (DN − expected) / σ over the unsaturated sites (0 and 1 for
// an unbiased readout with the stated sigma).
//
// Writes DIR/camera_frame.{csv,png,dat,gp} (DIR: bench/results).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "bench_cli.hpp"

#include "chart.hpp"
#include "chromo/simulators/camera/camera_model.hpp"
#include "clocks.hpp"
#include "guarded_main.hpp"

namespace chromo::bench {
namespace {

namespace fs = std::filesystem;
using simulators::CameraModel;
using simulators::SensorLayout;

constexpr double kExposureUs = 10000;

struct Timing {
  double cpu_ms = 1e300, wall_ms = 1e300;  // best of the repeats
};

struct NoiseCheck {
  double mean_offset_dn = 0, rms_z = 0;
};

// The response of the lit frame: a diagonal ramp from 0 to 1.2 × the full well.
cv::Mat lit_response(const CameraModel& model, int width, int height) {
  const double full_scale = model.options().full_well_e / (model.options().quantum_scale_e_per_us * kExposureUs);
  cv::Mat response(height, width, CV_32FC3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double t = 0.5 * (static_cast<double>(x) / width + static_cast<double>(y) / height);
      const float r = static_cast<float>(1.2 * full_scale * t);
      response.at<cv::Vec3f>(y, x) = cv::Vec3f(0.8f * r, r, 0.6f * r);
    }
  return response;
}

template <typename Readout>
Timing time_readout(int repeats, Readout readout, cv::Mat& frame) {
  Timing best;
  for (int k = 0; k < repeats; ++k) {
    const CpuClock cpu;
    const auto wall = std::chrono::steady_clock::now();
    frame = readout(static_cast<std::uint64_t>(k));
    best.cpu_ms = std::min(best.cpu_ms, 1e3 * cpu.seconds());
    best.wall_ms = std::min(best.wall_ms, 1e3 * seconds_since(wall));
  }
  return best;
}

// The frame's noise against the model's statement, Bayer RGGB sites at phase 0.
NoiseCheck check_noise(const CameraModel& model, const cv::Mat& response, const cv::Mat& dn) {
  double sum = 0, sum_z2 = 0;
  std::size_t n = 0;
  for (int y = 0; y < dn.rows; ++y)
    for (int x = 0; x < dn.cols; ++x) {
      const int c = (y & 1) == 0 ? ((x & 1) == 0 ? 0 : 1) : ((x & 1) == 0 ? 1 : 2);
      const double r = response.at<cv::Vec3f>(y, x)[c];
      const double expected = model.expected_dn(r, kExposureUs, 0);
      if (model.options().quantum_scale_e_per_us * kExposureUs * r > 0.95 * model.options().full_well_e) continue;
      const double d = dn.at<std::uint16_t>(y, x) - expected;
      sum += d;
      sum_z2 += std::pow(d / model.noise_sigma_dn(r, kExposureUs, 0), 2);
      ++n;
    }
  return {sum / n, std::sqrt(sum_z2 / n)};
}

int bench_main(int argc, char** argv) {
  CLI::App app{"camera_frame_bench: the camera readout of a 5-MP frame, single stream against bands"};
  std::vector<int> sensor{2448, 2048};
  int repeats = 3, threads = 0;
  bool no_chart = false;
  std::string out = CHROMO_BENCH_RESULTS;
  app.add_option("--sensor", sensor, "sensor width and height")->expected(2);
  app.add_option("--repeats", repeats, "readouts per frame and path (the best is kept)")->check(CLI::Range(1, 100));
  app.add_option("--threads", threads, "readout threads of the band path (0 = OpenMP's default)")->check(CLI::Range(0, 64));
  app.add_flag("--no-chart", no_chart, "no chart");
  app.add_option("--out", out, "where the CSV and chart go");
  CLI11_PARSE(app, argc, argv);
  if (sensor[0] < 2 || sensor[1] < 2) throw std::invalid_argument("--sensor: width and height must be >= 2");

  simulators::CameraModelOptions options;
  options.readout_threads = threads;
  const CameraModel model(options);
  options.readout_threads = 1;
  const CameraModel one_thread(options);
  const int width = sensor[0], height = sensor[1];
  std::printf("camera_frame_bench: %dx%d BayerRG12 (%.2f MP), %d ms exposure, best of %d; load average %.2f\n", width,
              height, width * height / 1e6, static_cast<int>(kExposureUs / 1000), repeats, load_average());

  struct Frame {
    const char* name;
    cv::Mat response;
  };
  const std::vector<Frame> frames = {{"lit", lit_response(model, width, height)},
                                     {"dark", cv::Mat(height, width, CV_32FC3, cv::Scalar::all(0))}};
  std::ofstream csv(fs::path(out) / "camera_frame.csv");
  csv << "frame,readout,cpu_ms,wall_ms,mean_offset_dn,rms_z\n";
  std::vector<Bar> bars;
  for (const Frame& f : frames) {
    cv::Mat dn;
    auto expose_with = [&](const CameraModel& m, bool single_stream) {
      return [&, single_stream](std::uint64_t k) {
        return single_stream ? m.expose_single_stream(f.response, SensorLayout::kBayerRGGB, 0, 0, kExposureUs, 0, k)
                             : m.expose(f.response, SensorLayout::kBayerRGGB, 0, 0, kExposureUs, 0, k);
      };
    };
    struct Row {
      const char* readout;
      Timing timing;
      NoiseCheck noise;
    };
    std::vector<Row> rows;
    const Timing single = time_readout(repeats, expose_with(model, true), dn);
    rows.push_back({"single stream", single, check_noise(model, f.response, dn)});
    const Timing bands = time_readout(repeats, expose_with(model, false), dn);
    rows.push_back({"bands", bands, check_noise(model, f.response, dn)});
    const Timing bands_1 = time_readout(repeats, expose_with(one_thread, false), dn);
    rows.push_back({"bands, 1 thread", bands_1, check_noise(model, f.response, dn)});
    std::printf("\n%s frame             CPU ms    wall ms   mean(DN-expected)  rms z\n", f.name);
    for (const Row& r : rows) {
      std::printf("  %-16s %9.1f %9.1f %14.4f %12.4f\n", r.readout, r.timing.cpu_ms, r.timing.wall_ms,
                  r.noise.mean_offset_dn, r.noise.rms_z);
      csv << f.name << ',' << r.readout << ',' << r.timing.cpu_ms << ',' << r.timing.wall_ms << ','
          << r.noise.mean_offset_dn << ',' << r.noise.rms_z << '\n';
      bars.push_back({std::string(f.name) + " " + r.readout + " CPU", r.timing.cpu_ms});
      bars.push_back({std::string(f.name) + " " + r.readout + " wall", r.timing.wall_ms});
    }
    std::printf("  single stream / bands: CPU %.2fx, wall %.2fx; single stream / bands on 1 thread: CPU %.2fx\n",
                single.cpu_ms / bands.cpu_ms, single.wall_ms / bands.wall_ms, single.cpu_ms / bands_1.cpu_ms);
  }
  std::printf("\nload average now %.2f\n", load_average());
  if (!no_chart)
    write_bar_chart(fs::path(out) / "camera_frame.png",
                    "Camera readout of one " + std::to_string(width) + "x" + std::to_string(height) + " frame",
                    "ms per frame (best of " + std::to_string(repeats) + ")", bars, true);
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("camera_frame_bench", chromo::bench::bench_main, argc, argv); }
