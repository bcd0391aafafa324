// Colour scales of the map explorer: viridis for continuous values between a
// low and a high end (linear or log), a categorical palette for codes (flags,
// model order), and the two colours that keep pixels without a value apart:
// masked by a flag (grey) and outside the lit field (black).

// Viridis, sampled at nine stops and interpolated linearly.
const VIRIDIS = [[68, 1, 84], [71, 44, 122], [59, 81, 139], [44, 113, 142], [33, 144, 141],
  [39, 173, 129], [92, 200, 99], [170, 220, 50], [253, 231, 37]];

// Paul Tol's "bright" and "muted" qualitative colours: distinct to
// colour-blind readers; index = code (0, explained, is the neutral one).
export const CATEGORY_COLOURS = [[221, 221, 221], [170, 51, 119], [238, 102, 119], [34, 136, 51], [204, 187, 68],
  [51, 34, 136], [102, 204, 238], [153, 153, 51], [68, 119, 170], [136, 34, 85]];

export const MASKED_COLOUR = [150, 150, 150];
export const OUTSIDE_COLOUR = [0, 0, 0];

export function viridis(t) {
  const x = Math.min(Math.max(t, 0), 1) * (VIRIDIS.length - 1);
  const i = Math.min(Math.floor(x), VIRIDIS.length - 2);
  const f = x - i;
  return VIRIDIS[i].map((a, k) => Math.round(a + (VIRIDIS[i + 1][k] - a) * f));
}

// Where a value sits between low and high (0-1, clamped), linear or log
// (log needs low > 0; values at or below 0 sit at the low end).
export function position(value, contrast) {
  const { low, high, log } = contrast;
  if (log) {
    const lo = Math.log(low), hi = Math.log(high);
    return Math.min(Math.max((Math.log(Math.max(value, low)) - lo) / (hi - lo || 1), 0), 1);
  }
  return Math.min(Math.max((value - low) / (high - low || 1), 0), 1);
}

export function valueAt(t, contrast) {
  const { low, high, log } = contrast;
  return log ? Math.exp(Math.log(low) + t * (Math.log(high) - Math.log(low))) : low + t * (high - low);
}

// Round tick values inside [low, high]: 1-2-5 steps (about `count` of them)
// on a linear scale, 1-2-5 per decade on a log scale.
export function ticks(contrast, count = 5) {
  const { low, high, log } = contrast;
  if (!(high > low)) return [low];
  if (log) {
    const out = [];
    for (let decade = Math.floor(Math.log10(low)); decade <= Math.ceil(Math.log10(high)); ++decade)
      for (const m of [1, 2, 5]) {
        const v = m * 10 ** decade;
        if (v >= low * (1 - 1e-9) && v <= high * (1 + 1e-9)) out.push(v);
      }
    return out.length > 1 ? out : [low, high];
  }
  const raw = (high - low) / count;
  const magnitude = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((m) => m * magnitude).find((s) => s >= raw);
  const out = [];
  for (let v = Math.ceil(low / step) * step; v <= high + step * 1e-9; v += step) out.push(Number(v.toPrecision(12)));
  return out;
}

// The p-th percentile (0-100) of ascending values, interpolating linearly
// between closest ranks (maps/region_statistics.hpp does the same).
export function percentileOfSorted(sorted, percent) {
  if (!sorted.length) return NaN;
  const rank = percent / 100 * (sorted.length - 1);
  const below = Math.floor(rank);
  const above = Math.min(below + 1, sorted.length - 1);
  return sorted[below] + (sorted[above] - sorted[below]) * (rank - below);
}

// ColorBrewer's RdBu (reversed: negative blue, zero white, positive red) for
// a signed quantity such as a difference's z; t in 0-1, 0.5 is zero.
const DIVERGING = [[33, 102, 172], [103, 169, 207], [209, 229, 240], [247, 247, 247], [253, 219, 199], [239, 138, 98], [178, 24, 43]];
export function diverging(t) {
  const x = Math.min(Math.max(t, 0), 1) * (DIVERGING.length - 1);
  const i = Math.min(Math.floor(x), DIVERGING.length - 2);
  const f = x - i;
  return DIVERGING[i].map((a, k) => Math.round(a + (DIVERGING[i + 1][k] - a) * f));
}
