// The polarised surface correction (measurement_surface.hpp).
#include "measurement_surface.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "chromo/estimation/highlight_flags.hpp"

namespace chromo::session::measurement {

std::array<std::vector<std::uint8_t>, 3> add_surface_map(Measurement& m, const Captures& captures,
                                                         const References& references, const Normalised& cross) {
  const IlluminatedCapture& capture = *captures.parallel;
  const Normalised parallel = normalise(capture, *references.parallel, captures.dark, captures.white_reflectance);
  std::array<double, 3> divisor{2, 2, 2};  // c_parallel − c_cross of ideal films
  if (const auto& factors = captures.surface_factors) {
    auto& correction = m.surface_correction.emplace();
    correction.source = factors->source;
    for (int c = 0; c < 3; ++c) {
      divisor[c] = channel_surface_factor(factors->parallel, captures.camera, capture.illuminant, c) -
                   channel_surface_factor(factors->cross, captures.camera, captures.captures.front().illuminant, c);
      if (!(divisor[c] > 0.05))
        throw std::invalid_argument("surface factors (" + factors->source + "): the parallel capture keeps " +
                                    std::to_string(divisor[c]) + " more of the surface light than the cross one in channel " +
                                    kChannelNames[c] + "; films that barely polarise cannot separate it");
      correction.parallel_minus_cross[c] = divisor[c];
    }
  }
  const std::size_t n = cross.albedo[1].size();
  std::array<std::vector<float>*, 3> maps{&m.surface_red, &m.surface, &m.surface_blue};
  std::array<std::vector<std::uint8_t>, 3> saturated;
  for (int c = 0; c < 3; ++c) {
    maps[c]->assign(n, kNaN);
    saturated[c].assign(n, 0);
    const auto &p = parallel.albedo[c], &x = cross.albedo[c];
    const auto& raw = capture.subject.planes[c];
    for (std::size_t i = 0; i < n; ++i) {
      saturated[c][i] = raw[i] >= kRawSaturated;
      if (std::isfinite(p[i]) && std::isfinite(x[i]) && references.parallel->footprint.inside[i])
        (*maps[c])[i] = static_cast<float>((p[i] - x[i]) / divisor[c]);
    }
  }
  const estimation::ChannelNoise& cross_noise = references.capture_noise.front()[1];  // the cross capture's G
  m.surface_sigma.assign(n, kNaN);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(m.surface[i])) continue;
    const float p = parallel.albedo[1][i], c = cross.albedo[1][i];
    m.surface_sigma[i] = static_cast<float>(
        std::sqrt(cross_noise.variance(std::max(0.0f, c)) + references.parallel_green_noise.variance(std::max(0.0f, p))) /
        divisor[1]);
  }
  return saturated;
}

namespace {

double median_of_finite(const std::vector<float>& values) {
  std::vector<float> finite;
  finite.reserve(values.size());
  for (float v : values)
    if (std::isfinite(v)) finite.push_back(v);
  if (finite.empty()) return 0.0;
  const auto middle = finite.begin() + static_cast<std::ptrdiff_t>(finite.size() / 2);
  std::nth_element(finite.begin(), middle, finite.end());
  return *middle;
}

}  // namespace

void remove_surface_light(Measurement& m, const Captures& captures,
                          const std::array<std::vector<std::uint8_t>, 3>& parallel_saturated,
                          std::vector<Normalised>& cross_captures) {
  auto& correction = *m.surface_correction;
  const SurfaceFactors& factors = *captures.surface_factors;
  const std::array<const std::vector<float>*, 3> maps{&m.surface_red, &m.surface, &m.surface_blue};
  correction.cross_factor.resize(captures.captures.size());
  for (int c = 0; c < 3; ++c) {
    correction.sheen_reference[c] = std::min(median_of_finite(*maps[c]), estimation::kSheenAtNormal);
    for (std::size_t k = 0; k < captures.captures.size(); ++k)
      correction.cross_factor[k][c] =
          channel_surface_factor(factors.cross, captures.camera, captures.captures[k].illuminant, c);
  }
  const std::size_t n = m.surface.size();
  for (std::size_t i = 0; i < n; ++i) {
    const float g = m.surface[i];
    const bool significant = std::isfinite(g) && g - correction.sheen_reference[1] >= kSurfaceCorrectionSigmas * m.surface_sigma[i];
    if (!significant) continue;
    ++correction.corrected_pixels;
    for (int c = 0; c < 3; ++c) {
      const double surface = parallel_saturated[c][i] || !std::isfinite((*maps[c])[i]) ? g : (*maps[c])[i];
      const double excess = surface - correction.sheen_reference[c];
      for (std::size_t k = 0; k < cross_captures.size(); ++k) {
        float& a = cross_captures[k].albedo[c][i];
        if (std::isfinite(a)) a -= static_cast<float>(correction.cross_factor[k][c] * excess);
      }
    }
  }
}

}  // namespace chromo::session::measurement
