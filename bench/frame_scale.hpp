#pragma once
// The frame scale of the learned discrepancy (estimation/discrepancy_scale.hpp)
// as real_skin_bench applies it, and the leave-one-subject-out scales that
// justify its bound.
//
// Frames: the bench's scene holds the fold's held-out subjects as patches
// of `patch` consecutive pixels (subject j: pixels [j·patch, (j+1)·patch),
// its ink, marker, vein and highlights drawn on the patch). A lab frame
// holds one subject, so kPerSubject estimates the scale on each patch alone
// (the patch is that subject's frame: every pixel is rendered and estimated
// independently, so cutting the scene changes nothing else); kOneFrame on
// the whole scene (the old one-frame layout, for comparison); kFixed applies
// a given scale to every pixel (the ink check at the bound).

#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "chromo/estimation/discrepancy_scale.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/simulators/scene/synthetic.hpp"

namespace chromo::bench {

struct FrameScaleMode {
  enum Kind { kNone, kFixed, kPerSubject, kOneFrame } kind = kNone;
  double fixed = 1;
  estimation::DiscrepancyScaleOptions options;
};

// A part of the scene and the estimator it is estimated with.
struct ScaledPart {
  std::size_t begin = 0, end = 0;  // pixels
  estimation::Estimator estimator;
  double scale = 1, weight = 0;  // the frame's scale and the weight of its own term (discrepancy_scale.hpp)
};

inline std::vector<ScaledPart> scaled_parts(const estimation::Estimator& base, std::span<const float> measured,
                                            const FrameScaleMode& mode, std::size_t patch) {
  const std::size_t channels = static_cast<std::size_t>(base.channels()), pixels = measured.size() / channels;
  std::vector<ScaledPart> parts;
  const std::size_t step = mode.kind == FrameScaleMode::kPerSubject ? patch : pixels;
  for (std::size_t begin = 0; begin < pixels; begin += step) {
    const std::size_t end = std::min(pixels, begin + step);
    const auto values = measured.subspan(begin * channels, (end - begin) * channels);
    if (mode.kind == FrameScaleMode::kNone) parts.push_back({begin, end, base});
    else if (mode.kind == FrameScaleMode::kFixed) parts.push_back({begin, end, base.with_discrepancy_scale(mode.fixed), mode.fixed, 0});
    else {
      estimation::FrameEstimator f = estimation::frame_estimator(base, values, {}, mode.options);
      parts.push_back({begin, end, std::move(f.estimator), f.scale.scale, f.scale.weight});
    }
  }
  return parts;
}

inline void estimate_parts(const std::vector<ScaledPart>& parts, std::span<const float> measured,
                           std::span<estimation::PixelEstimate> out) {
  for (const ScaledPart& p : parts) {
    const std::size_t channels = static_cast<std::size_t>(p.estimator.channels());
    p.estimator.estimate(measured.subspan(p.begin * channels, (p.end - p.begin) * channels), out.subspan(p.begin, p.end - p.begin));
  }
}

// Leave-one-subject-out: each training subject's own frame statistic under
// the discrepancy learned from the other training subjects, on a uniform
// noisy patch of its spectrum (texture, no anomalies): its scale and the
// weight its own term would need (unbounded). `base` holds the plan and its
// noise; train[k] is the residual of spectra[k].
inline std::vector<std::pair<double, double>> leave_one_out_scales(const estimation::Estimator& base, estimation::MeasurementSet set,
                                                const std::vector<estimation::SpectrumResidual>& train,
                                                const std::vector<spectral::Spectrum>& spectra, int patch,
                                                std::uint64_t seed) {
  estimation::DiscrepancyScaleOptions options;
  options.max_weight = 1e3;  // the unbounded statistic is what is wanted
  std::vector<std::pair<double, double>> out;
  for (std::size_t k = 0; k < train.size(); ++k) {
    std::vector<estimation::SpectrumResidual> others;
    for (std::size_t j = 0; j < train.size(); ++j)
      if (j != k) others.push_back(train[j]);
    const auto learned = std::make_shared<const estimation::ModelDiscrepancy>(estimation::ModelDiscrepancy::learn(others));
    simulators::SyntheticOptions o;
    o.seed = seed * 1000 + k;
    o.noise.noise_scale = 0;
    o.pixels = patch;
    o.skin_spectra = {spectra[k]};
    o.patch_pixels = patch;
    estimation::MeasurementSet render_set = set;
    const simulators::SyntheticFrame frame = simulators::make_synthetic_frame(render_set, o);
    const std::vector<float> noisy = simulators::add_channel_noise(frame.clean, set, o.seed * 7919 + 1);
    const auto s = estimation::estimate_discrepancy_scale(base.with_discrepancy(learned), noisy, {}, options);
    out.push_back({s.scale, s.unbounded});
  }
  return out;
}

}  // namespace chromo::bench
