#pragma once
// The camera readout's random numbers (CameraModel::expose): one stream per
// band of sensor rows, a fast standard normal and an exact Poisson for small
// means.
//
// - Streams: xoshiro256+ (Blackman & Vigna 2018), seeded through SplitMix64
//   from (frame seed, band index) alone, so a frame's noise does not depend
//   on how many threads read its bands out, nor in which order.
// - Normal: Marsaglia & Tsang's ziggurat (2000, 128 layers; the tail beyond
//   r = 3.4426 by Marsaglia's exponential method), exact up to the 32-bit
//   resolution of its abscissae (steps of ~1.6e-9). The layer index comes
//   from bits 3-9 of a draw and the abscissa from bits 32-63, never the same
//   bits (the lowest bits of xoshiro256+ are its weakest and Marsaglia's
//   original shared them, Doornik 2005).
// - Poisson: inversion (chop-down search from 0), exact, for the means the
//   camera model draws exactly (below CameraModel's 30 electrons).
//
// Thread rules: a stream belongs to one thread; ZigguratNormal is immutable.

#include <cmath>
#include <cstdint>

namespace chromo::simulators::readout_random {

// Rows per band: the unit of the readout's streams and of its threads.
inline constexpr int kBandRows = 32;

// SplitMix64: advances `state` and returns its next output.
inline std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

class Xoshiro256Plus {
 public:
  // The four state words from SplitMix64 seeded with `seed` (never all zero).
  explicit Xoshiro256Plus(std::uint64_t seed) {
    for (std::uint64_t& word : s_) word = splitmix64(seed);
  }
  std::uint64_t next() {
    const std::uint64_t result = s_[0] + s_[3];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = (s_[3] << 45) | (s_[3] >> 19);
    return result;
  }
  // Uniform in the open interval (0, 1), from the 53 upper bits.
  double uniform_open() { return (static_cast<double>(next() >> 11) + 0.5) * 0x1.0p-53; }

 private:
  std::uint64_t s_[4];
};

// The stream of rows [band·kBandRows, (band+1)·kBandRows) of a frame.
inline Xoshiro256Plus band_stream(std::uint64_t frame_seed, std::uint64_t band) {
  std::uint64_t mix = frame_seed;
  const std::uint64_t frame_key = splitmix64(mix);
  return Xoshiro256Plus(frame_key ^ (band * 0xD1B54A32D192ED03ull));
}

class ZigguratNormal {
 public:
  ZigguratNormal();  // references the shared tables (built once)

  double operator()(Xoshiro256Plus& rng) const {
    const std::uint64_t u = rng.next();
    const int layer = static_cast<int>((u >> 3) & 127);
    const std::int64_t j = static_cast<std::int32_t>(u >> 32);
    if ((j < 0 ? -j : j) < tables_->k[layer]) return static_cast<double>(j) * tables_->w[layer];
    return wedge_or_tail(rng, layer, j);
  }

  struct Tables {
    std::int64_t k[128];  // |j| below k[i]: inside layer i's rectangle
    double w[128];        // abscissa per unit of j
    double f[128];        // exp(−x_i²/2) at the layer edges
  };

 private:
  double wedge_or_tail(Xoshiro256Plus& rng, int layer, std::int64_t j) const;
  const Tables* tables_;
};

// Exact Poisson(mean) by inversion; for small means (about mean + 1 steps).
inline long poisson_by_inversion(double mean, Xoshiro256Plus& rng) {
  double u = rng.uniform_open();
  double p = std::exp(-mean);
  long k = 0;
  while (u > p) {
    u -= p;
    ++k;
    p *= mean / static_cast<double>(k);
    if (p == 0) break;  // u above the summed mass by rounding (probability ~1e-16): the far tail
  }
  return k;
}

}  // namespace chromo::simulators::readout_random
