// A loaded map drawn into an image at its own grid (one pixel per GetMap
// cell): values in false colour between the contrast's ends, codes in
// categorical colours, and the pixels without a value kept apart: masked by
// a flag (grey) or outside the lit field or the skin (black: NaN, no_reference
// or white_target).
import { viridis, position, CATEGORY_COLOURS, MASKED_COLOUR, OUTSIDE_COLOUR } from './colour_scale.js';

export const NO_REFERENCE = 8;  // estimation/pixel_flags.hpp
export const WHITE_TARGET = 9;  // the white target in the subject's frame: not skin
const OUTSIDE_FLAGS = new Set([NO_REFERENCE, WHITE_TARGET]);
const SKIN_FLAGS = new Set([0, 4]);  // explained, specular: the previews colour these

export const isCategorical = (channel) => channel === 'flags' || channel === 'order';

// What a cell is: 'value', 'masked' or 'outside' (flags: the flags map's cell, or null).
export function cellKind(value, flag, categorical) {
  if (!Number.isFinite(value) || OUTSIDE_FLAGS.has(flag)) return 'outside';
  if (!categorical && flag !== null && !SKIN_FLAGS.has(flag)) return 'masked';
  return 'value';
}

export function categoryColour(channel, code) {
  if (channel === 'flags' && OUTSIDE_FLAGS.has(code)) return OUTSIDE_COLOUR;
  return CATEGORY_COLOURS[((code % CATEGORY_COLOURS.length) + CATEGORY_COLOURS.length) % CATEGORY_COLOURS.length];
}

// Draws `map` ({channel, width, height, values: Float64Array, flags: Float64Array or null})
// into `canvas` (resized to the grid); returns the count of each kind.
export function drawMapImage(canvas, map, contrast) {
  canvas.width = map.width;
  canvas.height = map.height;
  const context = canvas.getContext('2d');
  const image = context.createImageData(map.width, map.height);
  const categorical = isCategorical(map.channel);
  const counts = { value: 0, masked: 0, outside: 0 };
  for (let i = 0; i < map.values.length; ++i) {
    const v = map.values[i];
    const kind = cellKind(v, map.flags ? map.flags[i] : null, categorical);
    counts[kind] += 1;
    const rgb = kind === 'outside' ? OUTSIDE_COLOUR : kind === 'masked' ? MASKED_COLOUR
      : categorical ? categoryColour(map.channel, Math.round(v)) : viridis(position(v, contrast));
    image.data.set([rgb[0], rgb[1], rgb[2], 255], 4 * i);
  }
  context.putImageData(image, 0, 0);
  return counts;
}

// The finite values of the cells that are skin, ascending (the histogram's and
// the percentile preset's sample).
export function skinValues(map) {
  const out = [];
  for (let i = 0; i < map.values.length; ++i)
    if (cellKind(map.values[i], map.flags ? map.flags[i] : null, false) === 'value') out.push(map.values[i]);
  return Float64Array.from(out).sort();
}
