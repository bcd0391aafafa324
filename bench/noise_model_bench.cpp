// Is the estimator's per-capture noise model right? (issue 37, part 1.)
// The virtual lab's standard session (rendered_session.hpp) is rendered with
// and without noise from the same scene; on skin cells the difference is
// exactly the capture chain's noise. Per channel it is compared with the
// noise model build_measurement estimated from the dark and white
// frames (measurement.hpp: σ² = read² + shot·a + white·a²):
//
//   ratio = mean over skin cells of (noisy − noise-free)² / mean of σ²(noise-free)
//
// for the estimator's four channels and each photograph's R, G, B (D65',
// W57, W57+blue: what a relit comparison reads its photograph noise from),
// per albedo tertile (a model linear in a where the truth has a² shows as a
// ratio that grows with the albedo). Also the photograph's own-noise ΔE94
// as the report computes it (maps::photograph_noise_delta_e94_map: the
// photograph against itself plus one draw of its model) against the true
// one (the noisy photograph against the noise-free one).
//
//   noise_model_bench [--seeds 11,12] [--sensor 512 384] [--out bench/results]
//
// Configurations: the daemon's defaults (metered whites, blue ratio 8, one
// subject frame, 4 reference frames), one reference frame, and 4 subject
// frames. Writes OUT/noise_model.csv and OUT/noise_model.png (the ratio per
// channel, mean over seeds, per configuration).
#include "bench_cli.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "chart.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "guarded_main.hpp"

namespace chromo::bench {
namespace {

struct Config {
  std::string name;
  int frames = 1, reference_frames = 4;
};

// Σ (noisy − clean)² and Σ σ²(clean) per albedo tertile (0-2) and in all (3).
struct Ratio {
  std::array<double, 4> measured{}, predicted{};
  void add(int tertile, double noisy, double clean, double variance) {
    for (int t : {tertile, 3}) measured[t] += (noisy - clean) * (noisy - clean), predicted[t] += variance;
  }
  double of(int t) const { return predicted[t] > 0 ? measured[t] / predicted[t] : NAN; }
};

int tertile_of(double a, double low, double high) { return a < low ? 0 : a < high ? 1 : 2; }

int run(int argc, char** argv) {
  CLI::App app{"noise_model_bench: the estimator's noise model against the lab's noise"};
  std::vector<std::uint64_t> seeds{11, 12};
  std::vector<int> sensor{512, 384};
  std::filesystem::path out = "bench/results";
  app.add_option("--seeds", seeds)->delimiter(',');
  app.add_option("--sensor", sensor)->expected(2);
  app.add_option("--out", out);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  const std::vector<Config> configs{{"default (1 frame, 4 ref.)", 1, 4}, {"1 reference frame", 1, 1}, {"4 frames, 4 ref.", 4, 4}};
  std::filesystem::create_directories(out);
  std::ofstream csv(out / "noise_model.csv");
  csv << "config,seed,channel,ratio_low,ratio_mid,ratio_high,ratio_all\n";
  std::vector<Bar> bars;
  std::printf("noise_model_bench: standard session, metered whites, blue ratio 8, sensor %dx%d, skin cells\n", sensor[0], sensor[1]);
  std::printf("ratio = measured noise variance / the model's (1 = right), per albedo tertile low/mid/high and all\n\n");
  for (const Config& config : configs) {
    std::vector<std::string> names;
    std::vector<std::vector<double>> all_ratio;  // per channel, per seed
    for (std::uint64_t seed : seeds) {
      simulators::RenderedSessionOptions o;
      o.sensor_width = sensor[0], o.sensor_height = sensor[1];
      o.seed = seed;
      o.exposure_per_capture = true;
      o.blue_ratio = 8;
      o.frames_per_capture = config.frames;
      o.reference_frames = config.reference_frames;
      const simulators::RenderedSession s = simulators::render_session(o);
      std::vector<std::size_t> skin;
      for (std::size_t i = 0; i < s.region.size(); ++i)
        if (s.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin)) skin.push_back(i);
      // Channels: the estimator's four, then each photograph's three.
      struct Channel {
        std::string name;
        std::vector<double> noisy, clean;
        estimation::ChannelNoise noise;
      };
      std::vector<Channel> channels;
      const std::size_t count = s.noisy.set.size();
      for (std::size_t c = 0; c < count; ++c) {
        Channel ch{s.noisy.set.channels[c].name, {}, {}, s.noisy.set.channels[c].noise};
        for (std::size_t i : skin)
          ch.noisy.push_back(s.noisy.measured[i * count + c]), ch.clean.push_back(s.noise_free.measured[i * count + c]);
        channels.push_back(std::move(ch));
      }
      for (std::size_t p = 0; p < s.noisy.photographs.size(); ++p) {
        const session::Photograph &noisy = s.noisy.photographs[p], &clean = s.noise_free.photographs[p];
        for (int c = 0; c < 3; ++c) {
          Channel ch{"photo " + noisy.name + "." + "RGB"[c], {}, {}, (*noisy.noise)[static_cast<std::size_t>(c)]};
          for (std::size_t i : skin) ch.noisy.push_back(noisy.rgb[i][c]), ch.clean.push_back(clean.rgb[i][c]);
          channels.push_back(std::move(ch));
        }
        // The photograph's own noise as ΔE94: the report's figure and the truth.
        std::vector<Eigen::Vector3d> photo_noisy, photo_clean;
        for (std::size_t i : skin) photo_noisy.push_back(noisy.rgb[i]), photo_clean.push_back(clean.rgb[i]);
        const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
        const std::vector<double> model =
            maps::photograph_noise_delta_e94_map(photo_noisy, *noisy.noise, camera, noisy.illuminant, 1 + p);
        const maps::DeltaEStats truth = maps::photo_delta_e94(photo_clean, photo_noisy, camera, noisy.illuminant);
        double mean_model = 0;
        for (double v : model) mean_model += v / static_cast<double>(model.size());
        std::printf("%-26s seed %3llu photograph %-9s own-noise ΔE94: report's model %.3f, true (noisy vs noise-free) %.3f\n",
                    config.name.c_str(), static_cast<unsigned long long>(seed), noisy.name.c_str(), mean_model, truth.mean);
      }
      // The estimator on the noisy session, as chromod runs it (fast, auto,
      // the learned discrepancy) and without the discrepancy: the truth's χ²
      // per channel (noisy − noise-free against the model's σ: 1 when the
      // model is right), skin flagged, anomalies caught.
      {
        const auto table = estimation::ForwardTable::load_or_build(s.noisy.set, estimation::TableGrid{},
                                                                   estimation::ForwardTable::default_cache_dir(), nullptr, 2);
        const std::size_t count4 = s.noisy.set.size();
        double truth_chi2 = 0;
        for (std::size_t i : skin)
          for (std::size_t c = 0; c < count4; ++c) {
            const double clean = s.noise_free.measured[i * count4 + c], d = s.noisy.measured[i * count4 + c] - clean;
            truth_chi2 += d * d / s.noisy.set.channels[c].noise.variance(clean);
          }
        truth_chi2 /= static_cast<double>(skin.size() * count4);
        for (const bool learned : {false, true}) {
          estimation::EstimatorOptions eo;
          eo.threads = 2;
          if (learned) eo.discrepancy = estimation::ModelDiscrepancy::standard();
          std::vector<estimation::PixelEstimate> e(s.pixels());
          estimation::Estimator(table, s.noisy.set, eo).estimate(s.noisy.measured, e);
          std::array<std::size_t, 7> n{}, flagged{};
          for (std::size_t i = 0; i < s.pixels(); ++i) {
            if (s.region[i] >= n.size()) continue;
            ++n[s.region[i]];
            flagged[s.region[i]] += e[i].flag != estimation::PixelFlag::kExplained;
          }
          auto share = [&](simulators::SceneRegion r) {
            const auto k = static_cast<std::size_t>(r);
            return n[k] ? 100.0 * static_cast<double>(flagged[k]) / static_cast<double>(n[k]) : NAN;
          };
          using simulators::SceneRegion;
          std::printf("%-26s seed %3llu estimator (%s): truth χ²/channel %.3f; flagged: skin %.2f%%, tattoo %.1f%%, "
                      "marker %.1f%%, hair %.1f%%, vein %.1f%%\n",
                      config.name.c_str(), static_cast<unsigned long long>(seed), learned ? "learned discrepancy" : "noise only",
                      truth_chi2, share(SceneRegion::kSkin), share(SceneRegion::kTattoo), share(SceneRegion::kMarker),
                      share(SceneRegion::kHair), share(SceneRegion::kVein));
        }
      }
      if (names.empty()) {
        for (const Channel& ch : channels) names.push_back(ch.name);
        all_ratio.resize(channels.size());
      }
      for (std::size_t c = 0; c < channels.size(); ++c) {
        const Channel& ch = channels[c];
        std::vector<double> sorted = ch.clean;
        std::sort(sorted.begin(), sorted.end());
        const double low = sorted[sorted.size() / 3], high = sorted[2 * sorted.size() / 3];
        Ratio r;
        for (std::size_t k = 0; k < ch.clean.size(); ++k)
          r.add(tertile_of(ch.clean[k], low, high), ch.noisy[k], ch.clean[k], ch.noise.variance(ch.clean[k]));
        all_ratio[c].push_back(r.of(3));
        std::printf("%-26s seed %3llu %-20s albedo %.3f-%.3f  ratio %.3f %.3f %.3f  all %.3f\n", config.name.c_str(),
                    static_cast<unsigned long long>(seed), ch.name.c_str(), sorted.front(), sorted.back(), r.of(0), r.of(1), r.of(2),
                    r.of(3));
        csv << '"' << config.name << "\"," << seed << ',' << ch.name << ',' << r.of(0) << ',' << r.of(1) << ',' << r.of(2) << ','
            << r.of(3) << "\n";
      }
    }
    std::printf("%-26s mean over seeds:", config.name.c_str());
    for (std::size_t c = 0; c < names.size(); ++c) {
      double mean = 0;
      for (double v : all_ratio[c]) mean += v / static_cast<double>(all_ratio[c].size());
      std::printf(" %s %.2f;", names[c].c_str(), mean);
      if (c < 4 || names[c].find("photo") != std::string::npos)
        bars.push_back({config.name.substr(0, 8) + " " + names[c], mean});
    }
    std::printf("\n\n");
  }
  write_bar_chart(out / "noise_model.png", "measured noise variance over the model (skin cells)", "ratio", bars);
  std::printf("chart: %s\n", (out / "noise_model.png").c_str());
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("noise_model_bench", chromo::bench::run, argc, argv); }
