#include "chromo/simulators/camera/readout_random.hpp"

namespace chromo::simulators::readout_random {
namespace {

constexpr double kTailStart = 3.442619855899;         // r: the base layer's right edge
constexpr double kLayerArea = 9.91256303526217e-3;    // v: every layer's area (128 layers)
constexpr double kScale = 2147483648.0;               // 2^31: j's range

// Marsaglia & Tsang (2000), r4_nor_setup with double abscissae.
ZigguratNormal::Tables build_tables() {
  ZigguratNormal::Tables t{};
  double dn = kTailStart, tn = dn;
  const double q = kLayerArea / std::exp(-0.5 * dn * dn);
  t.k[0] = static_cast<std::int64_t>((dn / q) * kScale);
  t.k[1] = 0;
  t.w[0] = q / kScale;
  t.w[127] = dn / kScale;
  t.f[0] = 1.0;
  t.f[127] = std::exp(-0.5 * dn * dn);
  for (int i = 126; i >= 1; --i) {
    dn = std::sqrt(-2.0 * std::log(kLayerArea / dn + std::exp(-0.5 * dn * dn)));
    t.k[i + 1] = static_cast<std::int64_t>((dn / tn) * kScale);
    tn = dn;
    t.f[i] = std::exp(-0.5 * dn * dn);
    t.w[i] = dn / kScale;
  }
  return t;
}

const ZigguratNormal::Tables& shared_tables() {
  static const ZigguratNormal::Tables tables = build_tables();
  return tables;
}

}  // namespace

ZigguratNormal::ZigguratNormal() : tables_(&shared_tables()) {}

double ZigguratNormal::wedge_or_tail(Xoshiro256Plus& rng, int layer, std::int64_t j) const {
  const Tables& t = *tables_;
  for (;;) {
    if (layer == 0) {  // beyond r: Marsaglia's exponential method
      double x, y;
      do {
        x = -std::log(rng.uniform_open()) / kTailStart;
        y = -std::log(rng.uniform_open());
      } while (y + y < x * x);
      return j > 0 ? kTailStart + x : -kTailStart - x;
    }
    const double x = static_cast<double>(j) * t.w[layer];
    if (t.f[layer] + rng.uniform_open() * (t.f[layer - 1] - t.f[layer]) < std::exp(-0.5 * x * x)) return x;
    const std::uint64_t u = rng.next();
    layer = static_cast<int>((u >> 3) & 127);
    j = static_cast<std::int32_t>(u >> 32);
    if ((j < 0 ? -j : j) < t.k[layer]) return static_cast<double>(j) * t.w[layer];
  }
}

}  // namespace chromo::simulators::readout_random
