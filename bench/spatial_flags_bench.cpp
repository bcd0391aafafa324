// The spatial flag pass (estimation/spatial_flags.hpp) on the rendered 5-MP
// virtual-lab session (simulators/scene/rendered_session.hpp, the estimation bench's
// frame, read from its cache): flagged share per scene region and per band
// of the highlight's added reflection, and the pass's cost, for the pass on
// the cells themselves (block 1, its windows as tuned at 128-512 px) and on
// coarser levels (blocks of B × B cells), side by side on the same per-pixel
// estimate.
//
//   build/release/bin/spatial_flags_bench [--blocks 1,3,5] [--offsets N] [--scene-size W H]
//                                         [--frame-cache DIR] [--png PREFIX]
//
// Default blocks: 1 and the size NeighbourhoodOptions{} picks (block_px = 0).
// --offsets N: for each block size above 1, the pass again on N crops of the
// session that start (k mod B, 2k mod B) cells in (k < N): the same scene
// under N alignments of its blocks, and each region's lowest and highest
// flagged share (at 5 MP the highlight's share depends on a few seed cells,
// docs/estimation.md).
// Cost: wall clock and process CPU time (getrusage: both threads), per pass
// and per cell. Prints only; the figures go into docs/estimation.md.
#include <stdexcept>
#include <iostream>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "bench_cli.hpp"

#include "guarded_main.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/spatial_flags.hpp"
#include "chromo/simulators/scene/scene.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "clocks.hpp"
#include "lab_session.hpp"

namespace {

using namespace chromo;
using namespace chromo::estimation;

using bench::CpuClock;
using bench::seconds_since;

// Regions 0-6 (SceneRegion), 7 mixed cells; specular bands of added reflection.
constexpr int kRegions = 8;
const char* region_label(int region) {
  return region == 7 ? "mixed" : simulators::region_name(static_cast<simulators::SceneRegion>(region));
}
constexpr double kBandEdges[4] = {1.0, 0.03, 0.01, 0.0};

struct Shares {
  std::size_t total[kRegions] = {}, flagged[kRegions] = {}, band_total[3] = {}, band_flagged[3] = {};
  // Flagged skin cells: in the highlight's unlabelled tail (added reflection 0.001-0.006), within 8 cells of
  // another region, elsewhere.
  std::size_t skin_tail = 0, skin_edge = 0, skin_other = 0;
};

// The session's cells, or a crop of them (the flag pass's blocks then fall
// elsewhere on the scene): labels, the highlight's added reflection, the
// measurement and the first pass's estimates.
struct Frame {
  int width = 0, height = 0;
  std::vector<std::uint8_t> region;
  std::vector<float> reflection, measured;
  std::vector<PixelEstimate> estimates;
  std::size_t pixels() const { return region.size(); }
};

// The cells from (dx, dy) to the session's edge.
Frame crop(const simulators::RenderedSession& lab, const std::vector<float>& reflection,
           const std::vector<PixelEstimate>& estimates, int dx, int dy) {
  Frame f;
  f.width = lab.width - dx, f.height = lab.height - dy;
  const int channels = static_cast<int>(lab.noisy.set.size());
  for (int y = dy; y < lab.height; ++y)
    for (int x = dx; x < lab.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * lab.width + x;
      f.region.push_back(lab.region[i]);
      f.reflection.push_back(reflection[i]);
      f.estimates.push_back(estimates[i]);
      f.measured.insert(f.measured.end(), lab.noisy.measured.begin() + i * channels,
                        lab.noisy.measured.begin() + (i + 1) * channels);
    }
  return f;
}

Shares count(const Frame& frame, const std::vector<PixelEstimate>& e) {
  Shares s;
  const std::vector<float>& reflection = frame.reflection;
  cv::Mat other(frame.height, frame.width, CV_8U);
  for (std::size_t i = 0; i < frame.pixels(); ++i)
    other.at<std::uint8_t>(static_cast<int>(i / frame.width), static_cast<int>(i % frame.width)) =
        frame.region[i] != static_cast<std::uint8_t>(simulators::SceneRegion::kSkin);
  cv::dilate(other, other, cv::Mat::ones(17, 17, CV_8U));
  for (std::size_t i = 0; i < frame.pixels(); ++i) {
    if (frame.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin) && e[i].flag != PixelFlag::kExplained)
      ++(reflection[i] >= 0.001 ? s.skin_tail
         : other.at<std::uint8_t>(static_cast<int>(i / frame.width), static_cast<int>(i % frame.width)) ? s.skin_edge
                                                                                                         : s.skin_other);
  }
  for (std::size_t i = 0; i < frame.pixels(); ++i) {
    const int region = frame.region[i] == simulators::kMixedCell ? 7 : frame.region[i];
    const bool flagged = e[i].flag != PixelFlag::kExplained;
    ++s.total[region];
    s.flagged[region] += flagged;
    if (region == static_cast<int>(simulators::SceneRegion::kSpecular))
      for (int b = 0; b < 3; ++b)
        if (reflection[i] >= kBandEdges[b + 1] && reflection[i] < kBandEdges[b]) ++s.band_total[b], s.band_flagged[b] += flagged;
  }
  return s;
}

void print(const char* label, const Shares& s) {
  std::printf("%-22s", label);
  for (int k = 0; k < kRegions; ++k) {
    if (s.total[k] == 0) continue;
    std::printf(" %s %.2f%%", region_label(k), 100.0 * s.flagged[k] / s.total[k]);
  }
  std::printf(" | specular >=0.03 / 0.01-0.03 / 0.006-0.01:");
  for (int b = 0; b < 3; ++b) std::printf(" %.1f%%", s.band_total[b] ? 100.0 * s.band_flagged[b] / s.band_total[b] : 0.0);
  std::printf("\n%22s flagged skin cells: %zu in the highlight's unlabelled tail (reflection 0.001-0.006), %zu within 8 cells "
              "of another region, %zu elsewhere\n", "", s.skin_tail, s.skin_edge, s.skin_other);
}

}  // namespace

static int bench_main(int argc, char** argv) {
  int sensor_width = 2592, sensor_height = 1944;
  std::filesystem::path frame_cache = ForwardTable::default_cache_dir();
  std::vector<int> blocks;
  std::string png_prefix;
  int offsets = 0;
  std::vector<int> scene_size;
  CLI::App app{"The spatial flag pass on the rendered lab session, per block size (see the source's header)"};
  app.add_option("--blocks", blocks, "block sizes in cells, e.g. 1,3,5")->delimiter(',');
  app.add_option("--offsets", offsets, "count of shifted crops, 0-64")->check(CLI::Range(0, 64));
  app.add_option("--scene-size", scene_size, "the virtual lab's sensor, W H")->expected(2);
  app.add_option("--frame-cache", frame_cache, "the rendered session's cache directory");
  app.add_option("--png", png_prefix, "PREFIX of the flag images to write");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int status = app.exit(error);
    return status == 0 ? 0 : 2;
  }
  if (!scene_size.empty()) sensor_width = scene_size[0], sensor_height = scene_size[1];
  const simulators::RenderedSessionOptions ro = bench::lab_session_options(sensor_width, sensor_height, frame_cache);
  const simulators::RenderedSession lab = bench::load_lab_session(ro);
  const std::vector<float> reflection = simulators::cell_added_reflection(ro);
  const auto table = ForwardTable::load_or_build(lab.noisy.set, TableGrid{}, ForwardTable::default_cache_dir());
  EstimatorOptions eo;
  eo.threads = 2;
  const Estimator estimator(table, lab.noisy.set, eo);
  std::vector<PixelEstimate> per_pixel(lab.pixels());
  const EstimateSummary first = estimator.estimate(lab.noisy.measured, per_pixel);
  std::printf("first pass (fast auto, noisy): %.2f s wall, %.0f cells/s\n", first.seconds, lab.pixels() / first.seconds);
  const Frame whole = crop(lab, reflection, per_pixel, 0, 0);
  print("per pixel", count(whole, per_pixel));

  if (blocks.empty()) blocks = {1, neighbourhood_block_px(lab.width, lab.height, NeighbourhoodOptions{})};
  for (int block : blocks) {
    NeighbourhoodOptions no;
    no.block_px = block;
    std::vector<PixelEstimate> e = per_pixel;
    EstimateSummary summary = first;
    auto t = std::chrono::steady_clock::now();
    const CpuClock flags_clock;
    const NeighbourhoodSummary flags = refine_flags_with_neighbourhood(estimator, lab.noisy.measured, lab.width, lab.height, e, no);
    const double flags_s = seconds_since(t), flags_cpu = flags_clock.seconds();
    no.flags = false;
    t = std::chrono::steady_clock::now();
    const CpuClock order_clock;
    refine_with_neighbourhood(estimator, lab.noisy.measured, lab.width, lab.height, e, summary, no);
    const double order_s = seconds_since(t), order_cpu = order_clock.seconds();
    char label[64];
    std::snprintf(label, sizeof label, "block %d (%dx%d)", block, (lab.width + block - 1) / block,
                  (lab.height + block - 1) / block);
    print(label, count(whole, e));
    if (!png_prefix.empty()) {
      // Flagged skin red, flagged other regions grey, explained other regions dark blue.
      cv::Mat image(lab.height, lab.width, CV_8UC3, cv::Scalar(0, 0, 0));
      for (std::size_t i = 0; i < lab.pixels(); ++i) {
        const bool skin = lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin);
        const bool flagged = e[i].flag != PixelFlag::kExplained;
        image.at<cv::Vec3b>(static_cast<int>(i / lab.width), static_cast<int>(i % lab.width)) =
            skin ? (flagged ? cv::Vec3b(0, 0, 255) : cv::Vec3b(0, 0, 0)) : (flagged ? cv::Vec3b(128, 128, 128) : cv::Vec3b(128, 0, 0));
      }
      cv::imwrite(png_prefix + "_block" + std::to_string(block) + ".png", image);
    }
    std::printf("  flag pass %.2f s wall, %.2f s CPU (%.2f µs CPU per cell), %d rounds, %zu joined + %zu enclosed cells; "
                "order pooling %.2f s wall, %.2f s CPU\n",
                flags_s, flags_cpu, 1e6 * flags_cpu / lab.pixels(), flags.passes, flags.flagged_touching,
                flags.flagged_holes, order_s, order_cpu);
    if (offsets < 2 || block < 2) continue;
    // The same passes (flags, then the order pooling) on crops that start
    // (dx, dy) cells in, so that the blocks fall elsewhere on the scene:
    // every dx and every dy of the block once. How much a region's share
    // depends on where the blocks fall.
    NeighbourhoodOptions both = no;
    both.flags = true;
    double low[kRegions], high[kRegions];
    std::fill_n(low, kRegions, 1.0), std::fill_n(high, kRegions, 0.0);
    for (int k = 0; k < offsets; ++k) {
      const int dx = k % block, dy = (2 * k) % block;
      Frame f = crop(lab, reflection, per_pixel, dx, dy);
      EstimateSummary crop_summary;
      refine_with_neighbourhood(estimator, f.measured, f.width, f.height, f.estimates, crop_summary, both);
      const Shares shares = count(f, f.estimates);
      std::snprintf(label, sizeof label, "  crop +%d,+%d", dx, dy);
      print(label, shares);
      for (int r = 0; r < kRegions; ++r) {
        if (!shares.total[r]) continue;
        const double share = static_cast<double>(shares.flagged[r]) / shares.total[r];
        low[r] = std::min(low[r], share), high[r] = std::max(high[r], share);
      }
    }
    std::printf("  block %d over %d block alignments, flagged share per region (lowest - highest):", block, offsets);
    for (int r = 0; r < kRegions; ++r) {
      if (low[r] > high[r]) continue;
      std::printf(" %s %.2f-%.2f%%", region_label(r), 100 * low[r], 100 * high[r]);
    }
    std::printf("\n");
  }
  return 0;
}

int main(int argc, char** argv) { return chromo::bench::guarded_main("spatial_flags_bench", bench_main, argc, argv); }
