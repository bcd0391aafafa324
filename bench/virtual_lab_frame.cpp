#include "virtual_lab_frame.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <random>

#include "chromo/simulators/scene/scene.hpp"

using namespace chromo;

LabFrame render_lab_frame(estimation::MeasurementSet& set, const estimation::CameraNoiseModel& noise, int scene_width,
                          int scene_height, int width, int height, std::uint64_t seed) {
  const estimation::ChannelNoise channel_noise = noise.channel_noise();
  for (estimation::MeasurementChannel& c : set.channels) {
    c.noise = channel_noise;
    if (c.name == "blue.B") c.noise.read_sigma *= std::sqrt(2.0);  // a difference of two captures
  }
  simulators::SkinSceneOptions o;
  o.width = scene_width, o.height = scene_height, o.seed = seed, o.white_patch = false;
  const simulators::Scene scene = simulators::make_skin_scene(o);
  const int channels = set.size();
  const cv::Mat rendered = scene.render(set.weights());  // CV_32FC(channels), scene resolution
  cv::Mat measured, regions, maps[4];
  const cv::Size size(width, height);
  cv::resize(rendered, measured, size, 0, 0, cv::INTER_LINEAR);
  cv::resize(scene.regions(), regions, size, 0, 0, cv::INTER_NEAREST);
  const cv::Mat* truth_maps[4] = {&scene.cm(), &scene.ch(), &scene.bm(), &scene.che()};
  for (int k = 0; k < 4; ++k) cv::resize(*truth_maps[k], maps[k], size, 0, 0, cv::INTER_LINEAR);

  LabFrame f;
  f.width = width, f.height = height;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  f.clean.resize(pixels * channels), f.noisy.resize(pixels * channels);
  f.truth.resize(pixels), f.region.resize(pixels);
  std::mt19937_64 rng(seed * 7919 + 17);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double step = noise.full_scale_albedo / 4095.0;
  for (int y = 0; y < height; ++y) {
    const float* row = measured.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      f.region[i] = regions.at<std::uint8_t>(y, x);
      f.truth[i] = {maps[0].at<float>(y, x), maps[1].at<float>(y, x), maps[2].at<float>(y, x), maps[3].at<float>(y, x)};
      for (int c = 0; c < channels; ++c) {
        const double clean = std::min<double>(row[x * channels + c], noise.full_scale_albedo);
        double noisy = clean;
        if (noise.noise_scale > 0) {
          noisy = clean + std::sqrt(set.channels[c].noise.variance(clean)) * gauss(rng);
          noisy = std::clamp(std::round(noisy / step) * step, 0.0, noise.full_scale_albedo);
        }
        f.clean[i * channels + c] = static_cast<float>(clean);
        f.noisy[i * channels + c] = static_cast<float>(noisy);
      }
    }
  }
  return f;
}
