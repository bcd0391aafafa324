// "Before and after" on the Results page (docs/web.md; docs/maps.md "Two
// sessions side by side"): this session and another of the same subject
// compared by chromod (MapsService.CompareSessions, what `chromo maps
// compare` prints): the older session is "before", the after maps are
// registered onto its grid; the difference map is drawn as z = difference / σ
// (blue lower, red higher, black not compared), the difference itself or its
// σ per pixel, with the difference and its σ under the cursor; the region's statistics in both sessions and its median
// difference against its noise, the verdict.
import * as api from '../api.js';
import { h, field, messageArea, table, formatNumber, decodeBase64 } from '../dom.js';
import { diverging, viridis, ticks, percentileOfSorted, OUTSIDE_COLOUR } from './colour_scale.js';
import { linkedView } from './linked_view.js';
import { mapExplorer } from '../map_explorer.js';

const CHANNELS = ['Ch', 'Cm', 'Bm', 'Che'];  // the parameters with σ maps
const MAP_WIDTH = 480;                        // the difference map's cells across
const BAR_WIDTH = 320;
const unpack = (base64) => new Float32Array(decodeBase64(base64).buffer);

// A camera of `results` (GetResults) by name, else its first.
const cameraOf = (results, name) => (results.cameras ?? []).find((c) => c.camera === name) ?? (results.cameras ?? [])[0];

// Both sessions' maps side by side, one map explorer each (any channel, its
// contrast, σ and region), their zoom, pan and region linked with each other
// only. The after maps as captured, not registered: with the subject moved,
// a point of the skin sits apart in the two (the difference map above is
// registered). sides: [{id, file, pixelMm, label}] before then after.
function sideBySide(sides) {
  const view = linkedView();
  return h('div', { class: 'side-by-side' }, h('h4', {}, 'Both sessions side by side'),
    h('p', {}, 'Zoom, pan and the region move both maps together. The after maps are shown as captured (not registered onto before).'),
    h('div', { class: 'explorers' }, sides.map((side) => h('div', { 'data-session': side.id }, h('p', {}, side.label),
      mapExplorer(side.id, side.file, side.label, view, side.pixelMm)))));
}

// The session's maps file of camera `name` (relative to its folder), or null.
function mapsFileOf(results, name) {
  const camera = cameraOf(results, name);
  if (!camera?.maps_file) return null;
  const prefix = `${results.folder}/`;
  return camera.maps_file.startsWith(prefix) ? camera.maps_file.slice(prefix.length) : camera.maps_file;
}

// A colour bar: `colourAt(t)` for t in 0-1 from low to high, ticks with `tickText`.
function colourBar(colourAt, low, high, tickValues, tickText, label) {
  const bar = h('canvas', { class: 'colour-bar difference-bar', width: BAR_WIDTH, height: 34, role: 'img' });
  const context = bar.getContext('2d');
  for (let x = 0; x < bar.width; ++x) {
    context.fillStyle = `rgb(${colourAt(x / (bar.width - 1)).join(',')})`;
    context.fillRect(x, 0, 1, 12);
  }
  context.fillStyle = '#1d2430';
  context.font = '10px sans-serif';
  for (const value of tickValues) {
    const x = Math.round((value - low) / (high - low) * (bar.width - 1));
    context.fillRect(x, 12, 1, 5);
    const text = tickText(value);
    const width = context.measureText(text).width;
    context.fillText(text, Math.min(Math.max(0, x - width / 2), bar.width - width), 28);
  }
  bar.dataset.ticks = tickValues.join(' ');
  bar.dataset.range = `${low} ${high}`;
  bar.setAttribute('aria-label', label);
  return bar;
}

// The 99th percentile of the finite values of `values` (a layer's scale end).
function p99(values) {
  return percentileOfSorted(Float64Array.from(values.filter(Number.isFinite)).sort(), 99);
}

// What the difference map can draw, per pixel: z (from −2 to +2 times the
// threshold), the difference itself (± its 99th percentile of |difference|)
// or its σ (0 to its 99th percentile), each with its colour bar.
function layerScale(layer, reply, arrays, unit) {
  const threshold = reply.threshold_sigma;
  if (layer === 'z') {
    const end = 2 * threshold;
    return { low: -end, high: end, colourAt: diverging, ticks: [-2, -1, 0, 1, 2].map((k) => k * threshold),
      tickText: (z) => `${z > 0 ? '+' : ''}${formatNumber(z, 3)}σ`, title: `z of ${reply.channel} (after − before) / σ`,
      label: `z from ${-end} to ${end} σ: blue lower after, red higher after; black not compared` };
  }
  if (layer === 'difference') {
    const end = p99(arrays.difference.map(Math.abs)) || 1;
    return { low: -end, high: end, colourAt: diverging, ticks: ticks({ low: -end, high: end, log: false }, 4),
      tickText: (v) => formatNumber(v, 2), title: `${reply.channel} after − before${unit}`,
      label: `difference from ${formatNumber(-end, 3)} to ${formatNumber(end, 3)}${unit}: blue lower after, red higher after; black not compared` };
  }
  const end = p99(arrays.sigma) || 1;
  return { low: 0, high: end, colourAt: viridis, ticks: ticks({ low: 0, high: end, log: false }, 4),
    tickText: (v) => formatNumber(v, 2), title: `σ of the difference${unit} (both sessions' σ maps)`,
    label: `σ of the difference from 0 to ${formatNumber(end, 3)}${unit}; black not compared` };
}

// The difference map of a reply: a canvas with the region outlined, drawn as
// z, the difference or its σ (chosen), and the difference ± σ and z of the
// cell under the cursor.
function differenceMap(reply, region) {
  const width = reply.map_width, height = reply.map_height;
  const arrays = { difference: unpack(reply.difference_f32), sigma: unpack(reply.sigma_f32), z: unpack(reply.z_f32) };
  const { difference, sigma, z } = arrays;
  const unit = reply.before.unit ? ` ${reply.before.unit}` : '';
  const sourceWidth = reply.before.source_width, sourceHeight = reply.before.source_height;
  const canvas = h('canvas', { class: 'map-canvas difference-canvas', width: 2 * width, height: 2 * height, tabindex: 0,
    'aria-label': `${reply.channel} after − before; point at it for the difference and its σ` });
  const scaleBox = h('div', { class: 'contrast' });
  const layer = h('select', { name: 'difference_layer' }, h('option', { value: 'z' }, 'z = difference / σ'),
    h('option', { value: 'difference' }, 'the difference (after − before)'), h('option', { value: 'sigma' }, 'its σ per pixel'));
  const draw = () => {
    const scale = layerScale(layer.value, reply, arrays, unit);
    const values = arrays[layer.value];
    const image = document.createElement('canvas');
    image.width = width, image.height = height;
    const context = image.getContext('2d');
    const pixels = context.createImageData(width, height);
    for (let i = 0; i < width * height; ++i) {
      const rgb = Number.isFinite(z[i]) ? scale.colourAt((values[i] - scale.low) / (scale.high - scale.low)) : OUTSIDE_COLOUR;
      pixels.data.set([...rgb, 255], 4 * i);
    }
    context.putImageData(pixels, 0, 0);
    const view = canvas.getContext('2d', { willReadFrequently: true });
    view.imageSmoothingEnabled = false;
    view.drawImage(image, 0, 0, canvas.width, canvas.height);
    const sx = canvas.width / sourceWidth, sy = canvas.height / sourceHeight;
    view.lineWidth = 2;
    view.strokeStyle = '#1d2430';
    view.strokeRect(region.x * sx, region.y * sy, region.width * sx, region.height * sy);
    canvas.dataset.layer = layer.value;
    scaleBox.replaceChildren(h('span', { class: 'bar-title' }, scale.title),
      colourBar(scale.colourAt, scale.low, scale.high, scale.ticks, scale.tickText, scale.label),
      h('p', {}, `black: not compared. ${reply.significant_pixels} of ${reply.compared_pixels} compared pixels beyond ${formatNumber(reply.threshold_sigma)}σ on their own.`));
  };
  layer.addEventListener('change', draw);
  draw();
  const readout = h('output', { class: 'map-value difference-value', 'aria-live': 'polite' }, 'point at the map for the difference');
  const show = (cx, cy) => {
    const i = cy * width + cx;
    const x = Math.floor((cx + 0.5) * sourceWidth / width), y = Math.floor((cy + 0.5) * sourceHeight / height);
    readout.textContent = Number.isFinite(difference[i])
      ? `${reply.channel} after − before at pixel (${x}, ${y}): ${formatNumber(difference[i], 4)} ± ${formatNumber(sigma[i], 2)}${unit} (1σ), z ${formatNumber(z[i], 3)}`
      : `${reply.channel} at pixel (${x}, ${y}): not compared (not skin in both sessions)`;
    readout.dataset.cell = `${cx},${cy}`;
    readout.dataset.difference = String(difference[i]);
    readout.dataset.sigma = String(sigma[i]);
    readout.dataset.z = String(z[i]);
  };
  canvas.addEventListener('mousemove', (event) => {
    const box = canvas.getBoundingClientRect();
    show(Math.min(width - 1, Math.max(0, Math.floor((event.clientX - box.left) / box.width * width))),
      Math.min(height - 1, Math.max(0, Math.floor((event.clientY - box.top) / box.height * height))));
  });
  return h('div', {}, field('Draw', layer), h('div', { class: 'map-row' }, canvas, scaleBox, readout));
}

// The verdict and the region's numbers in both sessions.
function verdict(reply, before, after) {
  const r = reply.before.region;
  const unit = reply.before.unit ? ` ${reply.before.unit}` : '';
  const registration = reply.warped
    ? `after registered onto before: shift (${formatNumber(reply.shift_x_px, 3)}, ${formatNumber(reply.shift_y_px, 3)}) px, rotation ${formatNumber(reply.rotation_deg, 3)}°`
    : `not warped (motion ${formatNumber(reply.motion_px, 2)} px, within the registration's noise)`;
  const text = `${reply.channel} in ${r.width}×${r.height} px at (${r.x}, ${r.y}), ${reply.region_compared_pixels} pixels compared: ` +
    `median change ${formatNumber(reply.median_difference, 4)} ± ${formatNumber(reply.sigma_of_median, 2)}${unit} (1σ), z ${formatNumber(reply.z, 3)}: ` +
    (reply.significant ? `changed beyond ${formatNumber(reply.threshold_sigma)}σ.` : `no change beyond ${formatNumber(reply.threshold_sigma)}σ.`);
  const row = (name, s) => [name, ...[s.mean, s.sd, s.median, s.p5, s.p95].map((v) => formatNumber(v, 4)), s.pixels];
  return h('div', {},
    h('p', { class: `comparison-verdict ${reply.significant ? 'changed' : 'unchanged'}` }, text),
    h('p', {}, `Before: ${before}; after: ${after}; ${registration}.`),
    table(['Session', 'Mean', 'SD', 'Median', 'p5', 'p95', 'Pixels'],
      [row('before', reply.before), row('after (registered)', reply.after)], `${reply.channel} in the region, both sessions`));
}

// The card, for `results` (GetResults) of a session with results; null when
// the session has no maps.
export function comparisonSection(results) {
  const thisId = results.session_id;
  const other = h('select', { name: 'compare_with' }, h('option', { value: '' }, 'loading the sessions…'));
  const cameraNames = (results.cameras ?? []).map((c) => c.camera);
  const camera = h('select', {}, cameraNames.map((name) => h('option', { value: name }, name || 'the camera')));
  const channel = h('select', {}, CHANNELS.map((name) => h('option', { value: name }, name)));
  const threshold = h('input', { type: 'number', min: 0.5, max: 10, step: 0.5, value: 3 });
  const register = h('input', { type: 'checkbox', checked: true });
  const regionFields = ['x', 'y', 'width', 'height'].map(() => h('input', { type: 'number', min: 0, step: 1, class: 'region-field' }));
  const message = messageArea('comparison-message');
  const output = h('div', { class: 'comparison-output', 'aria-live': 'polite' });
  const submit = h('button', { type: 'submit', disabled: true }, 'Compare');
  const form = h('form', { class: 'inline comparison-form' },
    field('Compare with', other), field('Camera', camera), field('Map', channel), field('Threshold (σ)', threshold),
    ...['x (px)', 'y (px)', 'width (px)', 'height (px)'].map((label, i) => field(`Region ${label}`, regionFields[i])),
    h('label', { class: 'check' }, register, ' Register by the skin\'s texture'), submit);

  // The sessions of the same subject (every session when this one has none), newest first.
  const listed = api.call('SessionService', 'ListSessions', { limit: 200 }).then(({ sessions = [] }) => {
    const subject = sessions.find((s) => s.id === thisId)?.subject ?? '';
    const candidates = sessions.filter((s) => s.id !== thisId && s.operation?.state === 'OPERATION_STATE_SUCCEEDED' &&
      (!subject || s.subject === subject));
    other.replaceChildren(...(candidates.length
      ? candidates.map((s) => h('option', { value: s.id }, `${s.id}${s.subject ? ` (${s.subject})` : ''}`))
      : [h('option', { value: '' }, subject ? `no other session of ${subject}` : 'no other session')]));
    other.dataset.sessions = String(candidates.length);
    submit.disabled = candidates.length === 0;
  });
  // The region's default: the whole map (its size from a small GetMap of this session's maps).
  const sized = api.call('MapsService', 'GetMap', { session_id: thisId, maps_file: mapsFileOf(results, camera.value), channel: 'Cm', max_width: 16, packed: true })
    .then((map) => {
      [0, 0, map.source_width, map.source_height].forEach((v, i) => { if (regionFields[i].value === '') regionFields[i].value = String(v); });
    });
  Promise.all([listed, sized]).catch((error) => message.error(error));

  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    const otherId = other.value;
    if (!otherId) return;
    // Session ids begin with their UTC start time: the older one is "before".
    const [beforeId, afterId] = otherId < thisId ? [otherId, thisId] : [thisId, otherId];
    const region = Object.fromEntries(['x', 'y', 'width', 'height'].map((key, i) => [key, Number(regionFields[i].value)]));
    output.replaceChildren();
    output.dataset.state = 'loading';
    delete output.dataset.comparison;
    message.info(`comparing ${channel.value}…`);
    try {
      const otherResults = otherId === thisId ? results : await api.call('ResultsService', 'GetResults', { session_id: otherId });
      const files = { [thisId]: mapsFileOf(results, camera.value), [otherId]: mapsFileOf(otherResults, camera.value) };
      if (!files[otherId]) throw new Error(`session ${otherId} has no maps to compare with`);
      const request = { session_id: beforeId, maps_file: files[beforeId], after_session_id: afterId, after_maps_file: files[afterId],
        channel: channel.value, threshold_sigma: Number(threshold.value), region, no_registration: !register.checked, map_max_width: MAP_WIDTH };
      const reply = await api.call('MapsService', 'CompareSessions', request);
      message.clear();
      const pixelMm = { [thisId]: cameraOf(results, camera.value)?.summary?.map_pixel_mm ?? 0,
        [otherId]: cameraOf(otherResults, camera.value)?.summary?.map_pixel_mm ?? 0 };
      output.append(verdict(reply, beforeId, afterId), differenceMap(reply, region),
        sideBySide([[beforeId, 'before'], [afterId, 'after']].map(([id, role]) =>
          ({ id, file: files[id], pixelMm: pixelMm[id], label: `${role}: ${id}` }))));
      const { difference_f32: _d, sigma_f32: _s, z_f32: _z, ...numbers } = reply;
      output.dataset.comparison = JSON.stringify({ request, reply: numbers });
      output.dataset.state = 'ready';
    } catch (error) {
      output.dataset.state = 'error';
      message.error(error);
    }
  });
  return h('section', { class: 'card comparison', 'aria-labelledby': 'comparison-heading' },
    h('h3', { id: 'comparison-heading' }, 'Before and after: another session of this subject'),
    h('p', {}, 'The older session is "before"; the after maps are registered onto its grid. Per pixel the change is drawn against ' +
      'both sessions\' σ maps; over the region, the median change against its scatter says whether the region changed.'),
    form, message.element, output);
}
