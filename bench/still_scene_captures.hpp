#pragma once
// Captures of a real-skin scene with a known motion, for the registration
// benches: a noise-free `chromo make-real-skin-scene` MEASUREMENT.json (its
// pixels are the scene integrated over each pixel: a patch spectrum times a
// per-pixel texture), every image after the first moved by a known shift,
// then the declared camera noise added to every image.
//
// Moving a scene that is constant over each pixel by (tx, ty) and
// integrating it over the pixels again is bilinear interpolation of its
// pixels, exactly: moved(x) = scene(x + t) is cv::warpAffine (INTER_LINEAR,
// WARP_INVERSE_MAP) with the matrix [1 0 tx; 0 1 ty]. The registration that
// undoes it maps each reference pixel x to x − t in the moving image.

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "chromo/session/measurement_file.hpp"
#include "chromo/session/registration.hpp"

namespace chromo::bench {

// channel(x) ← channel(x + (tx, ty)), the frame's edge replicated.
inline void shift_channel(std::vector<float>& channel, int width, int height, double tx, double ty) {
  const cv::Mat src(height, width, CV_32F, channel.data());
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, tx, 0, 1, ty);
  cv::Mat dst;
  cv::warpAffine(src, dst, shift, src.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
  channel.assign(dst.ptr<float>(), dst.ptr<float>() + channel.size());
}

// `clean` (noise-free) with images 1… moved by (tx, ty) px and each value
// given its image's declared noise, σ² = read² + shot · max(v, 0), drawn
// from `seed`.
inline session::MeasurementFile moved_noisy_captures(const session::MeasurementFile& clean, double tx, double ty,
                                                     std::uint64_t seed) {
  session::MeasurementFile m = clean;
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + 17);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (std::size_t k = 0; k < m.images.size(); ++k) {
    session::MeasurementImage& image = m.images[k];
    for (auto& channel : image.pixels.channels) {
      if (k > 0 && (tx != 0 || ty != 0)) shift_channel(channel, m.width, m.height, tx, ty);
      for (float& v : channel)
        v = static_cast<float>(v + std::sqrt(image.noise.variance(v)) * gauss(rng));
    }
  }
  return m;
}

// Largest distance, over the image corners c, between where a registration
// sends c in the moving image (the identity when it was not warped) and where
// c truly is there, c − t.
inline double corner_error_px(const session::RegistrationReport& report, int width, int height, double tx, double ty) {
  double largest = 0;
  const auto& w = report.result.warp;
  for (double x : {0.0, width - 1.0})
    for (double y : {0.0, height - 1.0}) {
      const double mx = report.warped ? w[0][0] * x + w[0][1] * y + w[0][2] : x;
      const double my = report.warped ? w[1][0] * x + w[1][1] * y + w[1][2] : y;
      largest = std::max(largest, std::hypot(mx - (x - tx), my - (y - ty)));
    }
  return largest;
}

}  // namespace chromo::bench
