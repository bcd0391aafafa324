// One map of a session's maps.exr to read as a researcher does: any channel
// (MapsService.GetMap: each cell is the map's value at the cell's centre, so
// a value shown is a value the map holds) with its contrast, histogram and
// colour bar (maps/contrast.js), flags and order in categorical colours with
// a legend, masked and outside-the-field pixels apart, the value under the
// cursor with its σ (GetMap's sigma: the file's sigma_<channel>; packed
// float32, so a value shown is the map's float exactly), zoom, pan and region shared by
// every explorer of the page (maps/linked_view.js), and the region's
// statistics from chromod (maps/region_statistics.js).
//
// A value is never shown under another channel's name: every reply carries
// the channel it was asked for, a reply to an older request is dropped (and
// its request aborted), and the label and the value are written together
// from one loaded record.
// Keyboard: arrow keys move the cursor, Shift+arrows pan, + and - zoom, 0 shows the whole map.
import * as api from './api.js';
import { h, field, messageArea, formatNumber, decodeBase64 } from './dom.js';
import { contrastControls } from './maps/contrast.js';
import { drawMapImage, skinValues, cellKind, isCategorical } from './maps/map_image.js';
import { regionStatisticsPanel } from './maps/region_statistics.js';
import { drawScaleBar } from './maps/scale_bar.js';

const FIRST_CHANNELS = ['Cm', 'Ch', 'Bm', 'Che', 'residual', 'order', 'flags'];
const DISPLAY_WIDTH_PX = 960;  // the canvas's own pixels (shown 480 CSS pixels wide)
const SAMPLE_WIDTH = 480;      // GetMap's max_width
const SWITCH_SETTLE_MS = 150;  // a channel chosen is asked for once no other was chosen meanwhile

// GetMap's packed little-endian float32 bytes (base64 in the JSON) as numbers.
const unpack = (base64) => Float64Array.from(new Float32Array(decodeBase64(base64).buffer));

// Fraction of the map → a map pixel range [begin, end) of `size` pixels.
const pixelSpan = (from, to, size) => {
  const begin = Math.min(size - 1, Math.max(0, Math.floor(Math.min(from, to) * size + 1e-9)));
  const end = Math.max(begin + 1, Math.min(size, Math.ceil(Math.max(from, to) * size - 1e-9)));
  return [begin, end];
};

// pixelMm: one map pixel's width on the subject (ResultsSummary.map_pixel_mm), 0 or absent when unknown: no scale bar.
export function mapExplorer(sessionId, mapsFile, cameraName, view, pixelMm = 0) {
  const channel = h('select', {}, FIRST_CHANNELS.map((name) => h('option', { value: name }, name)));
  const loading = h('span', { class: 'map-loading', role: 'status' });
  const canvas = h('canvas', { class: 'map-canvas', tabindex: 0,
    'aria-label': `${cameraName} map; arrow keys move the cursor, Shift+arrows pan, + and - zoom, 0 shows the whole map; drag for a region` });
  const image = document.createElement('canvas');  // the map at its own grid
  const readout = h('output', { class: 'map-value', 'aria-live': 'polite' }, 'point at the map for its value');
  const message = messageArea();
  const region = regionStatisticsPanel(sessionId, mapsFile, cameraName);
  const section = h('section', { class: 'map-explorer', 'aria-label': `${cameraName}: map with the value under the cursor` });
  let map = null;     // the record drawn: {channel, values, sigma, flags, ...}
  let counts = { value: 0, masked: 0, outside: 0 };
  let cursor = { x: 0, y: 0 };  // a cell of the map's grid
  let drag = null;
  let flagsOfFile = null;  // the file's flags map, fetched once
  let generation = 0;
  let channelsListed = false;  // the select lists the file's own channels
  const contrast = contrastControls((chosen) => { redrawImage(chosen); });

  const redrawView = () => {
    if (!map) return;
    const context = canvas.getContext('2d');
    context.imageSmoothingEnabled = false;
    context.fillStyle = '#fff';
    context.fillRect(0, 0, canvas.width, canvas.height);
    const w = view.window();
    context.drawImage(image, w.x * image.width, w.y * image.height, w.size * image.width, w.size * image.height,
      0, 0, canvas.width, canvas.height);
    const box = drag?.moved ? drag : view.state.region;
    if (box) {
      const toCanvas = (fx, fy) => [(fx - w.x) / w.size * canvas.width, (fy - w.y) / w.size * canvas.height];
      const [ax, ay] = toCanvas(Math.min(box.x0, box.x1), Math.min(box.y0, box.y1));
      const [bx, by] = toCanvas(Math.max(box.x0, box.x1), Math.max(box.y0, box.y1));
      context.lineWidth = 3;
      context.strokeStyle = '#fff';
      context.strokeRect(ax, ay, bx - ax, by - ay);
      context.lineWidth = 1.5;
      context.strokeStyle = '#e8171f';
      context.strokeRect(ax, ay, bx - ax, by - ay);
    }
    const bar = drawScaleBar(context, map.source_width * w.size, pixelMm);
    if (bar) canvas.dataset.scaleBar = JSON.stringify(bar);
    else delete canvas.dataset.scaleBar;
    canvas.dataset.zoom = String(view.state.zoom);
  };
  function redrawImage(chosen) {
    counts = drawMapImage(image, map, chosen ?? contrast.contrast);
    contrast.draw(counts);
    redrawView();
  }

  const show = () => {
    if (!map) return;
    const i = cursor.y * map.width + cursor.x;
    const v = map.values[i];
    const flag = map.flags ? map.flags[i] : null;
    const sourceX = Math.floor((cursor.x + 0.5) * map.source_width / map.width);
    const sourceY = Math.floor((cursor.y + 0.5) * map.source_height / map.height);
    const kind = cellKind(v, flag, isCategorical(map.channel));
    const sigma = map.sigma && Number.isFinite(map.sigma[i]) ? ` ± ${formatNumber(map.sigma[i], 2)} (1σ)` : '';
    const unit = map.unit ? ` ${map.unit}` : '';
    const text = kind === 'outside' ? 'outside the lit field (no value)'
      : kind === 'masked' ? `masked: ${map.flag_names[flag] ?? `flag ${flag}`} (${formatNumber(v, 5)})`
      : map.channel === 'flags' ? `${v}: ${map.flag_names[v] ?? ''}`
      : `${formatNumber(v, 5)}${sigma}${unit}`;
    readout.textContent = `${map.channel} at pixel (${sourceX}, ${sourceY}): ${text}`;
    readout.dataset.channel = map.channel;
    readout.dataset.value = String(v);
    readout.dataset.sigma = map.sigma ? String(map.sigma[i]) : '';
    readout.dataset.cell = `${cursor.x},${cursor.y}`;
  };

  // The map region of the shared region fraction, in this map's pixels.
  const regionPixels = () => {
    const r = view.state.region;
    if (!r || !map) return null;
    const [x0, x1] = pixelSpan(r.x0, r.x1, map.source_width);
    const [y0, y1] = pixelSpan(r.y0, r.y1, map.source_height);
    return { x: x0, y: y0, width: x1 - x0, height: y1 - y0 };
  };
  const askStatistics = () => {
    const pixels = regionPixels();
    if (pixels) region.show(map.channel, pixels);
  };

  let inFlight = null;  // the AbortController of the load under way
  const fetchMap = (name, signal) =>
    api.call('MapsService', 'GetMap', { session_id: sessionId, maps_file: mapsFile, channel: name, max_width: SAMPLE_WIDTH, packed: true }, signal);
  const load = async () => {
    const wanted = channel.value;
    const mine = ++generation;
    inFlight?.abort();
    inFlight = new AbortController();
    const { signal } = inFlight;
    message.clear();
    loading.textContent = `loading ${wanted}…`;
    section.setAttribute('aria-busy', 'true');
    section.dataset.state = 'loading';
    canvas.classList.add('loading');
    readout.textContent = `loading ${wanted}…`;
    delete readout.dataset.channel;
    delete readout.dataset.value;
    try {
      // Channels stepped through quickly (arrow keys on the list) ask for the last one only.
      await new Promise((resolve) => { setTimeout(resolve, SWITCH_SETTLE_MS); });
      if (mine !== generation) return;
      const reply = await fetchMap(wanted, signal);
      const flags = flagsOfFile ?? (reply.channels.includes('flags') && wanted !== 'flags' ? await fetchMap('flags', signal) : null);
      if (mine !== generation) return;  // a newer channel was asked for meanwhile
      if (flags && !flagsOfFile) flagsOfFile = flags;
      if (!channelsListed && reply.channels.length) {
        channelsListed = true;
        const names = [...FIRST_CHANNELS.filter((n) => reply.channels.includes(n)), ...reply.channels.filter((n) => !FIRST_CHANNELS.includes(n))];
        channel.replaceChildren(...names.map((name) => h('option', { value: name, selected: name === wanted }, name)));
      }
      const values = unpack(reply.values_f32);
      const sigma = unpack(reply.sigma_f32);
      map = { ...reply, channel: wanted, values, sigma: sigma.length ? sigma : null,
        flags: wanted === 'flags' ? values : flagsOfFile ? unpack(flagsOfFile.values_f32) : null };
      contrast.load(map, skinValues(map));
      redrawImage();
      cursor = { x: Math.min(cursor.x, map.width - 1), y: Math.min(cursor.y, map.height - 1) };
      canvas.dataset.channel = wanted;
      show();
      askStatistics();
    } catch (error) {
      if (mine !== generation) return;
      map = null;
      readout.textContent = `${wanted}: not loaded`;
      message.error(error);
    } finally {
      if (mine === generation) {
        loading.textContent = '';
        section.removeAttribute('aria-busy');
        section.dataset.state = map ? 'ready' : 'error';
        canvas.classList.remove('loading');
      }
    }
  };

  // Pointer position → fraction of the map and the map cell under it.
  const fractionAt = (event) => {
    const box = canvas.getBoundingClientRect();
    const w = view.window();
    return { fx: w.x + (event.clientX - box.left) / box.width * w.size, fy: w.y + (event.clientY - box.top) / box.height * w.size };
  };
  const moveCursor = ({ fx, fy }) => {
    cursor = { x: Math.min(map.width - 1, Math.max(0, Math.floor(fx * map.width))),
               y: Math.min(map.height - 1, Math.max(0, Math.floor(fy * map.height))) };
    show();
  };
  canvas.addEventListener('mousedown', (event) => {
    if (!map || event.button !== 0) return;
    const at = fractionAt(event);
    drag = { pan: event.shiftKey, x0: at.fx, y0: at.fy, x1: at.fx, y1: at.fy, moved: false, clientX: event.clientX, clientY: event.clientY };
    event.preventDefault();
    canvas.focus();
  });
  canvas.addEventListener('mousemove', (event) => {
    if (!map) return;
    const at = fractionAt(event);
    moveCursor(at);
    if (!drag) return;
    if (Math.abs(event.clientX - drag.clientX) + Math.abs(event.clientY - drag.clientY) > 3) drag.moved = true;
    if (drag.pan) {
      const box = canvas.getBoundingClientRect();
      view.panBy(-(event.clientX - drag.clientX) / box.width * view.window().size, -(event.clientY - drag.clientY) / box.height * view.window().size);
      drag.clientX = event.clientX, drag.clientY = event.clientY;
      return;
    }
    drag.x1 = at.fx, drag.y1 = at.fy;
    redrawView();
  });
  window.addEventListener('mouseup', () => {
    if (!drag) return;
    const done = drag;
    drag = null;
    if (!done.pan && done.moved) view.setRegion({ x0: Math.min(done.x0, done.x1), y0: Math.min(done.y0, done.y1),
      x1: Math.max(done.x0, done.x1), y1: Math.max(done.y0, done.y1) });
  });
  canvas.addEventListener('wheel', (event) => {
    if (!map) return;
    event.preventDefault();
    const at = fractionAt(event);
    view.zoomBy(event.deltaY < 0 ? 1.25 : 0.8, at.fx, at.fy);
  }, { passive: false });
  canvas.addEventListener('keydown', (event) => {
    if (!map) return;
    const step = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1] }[event.key];
    if (step && event.shiftKey) view.panBy(step[0] * view.window().size / 8, step[1] * view.window().size / 8);
    else if (step) {
      cursor = { x: Math.min(map.width - 1, Math.max(0, cursor.x + step[0])), y: Math.min(map.height - 1, Math.max(0, cursor.y + step[1])) };
      show();
    } else if (event.key === '+' || event.key === '=') view.zoomBy(1.25);
    else if (event.key === '-') view.zoomBy(0.8);
    else if (event.key === '0') view.reset();
    else return;
    event.preventDefault();
  });
  region.form.addEventListener('submit', (event) => {
    event.preventDefault();
    const typed = region.typed();
    if (!map || !typed) return;
    view.setRegion({ x0: typed.x / map.source_width, y0: typed.y / map.source_height,
      x1: (typed.x + typed.width) / map.source_width, y1: (typed.y + typed.height) / map.source_height });
  });
  view.subscribe((what) => {
    redrawView();
    if (what === 'region' && map) askStatistics();
  });
  channel.addEventListener('change', load);
  const zoomButtons = h('div', { class: 'inline zoom' },
    h('button', { type: 'button', onclick: () => view.zoomBy(1.5) }, 'Zoom in'),
    h('button', { type: 'button', onclick: () => view.zoomBy(1 / 1.5) }, 'Zoom out'),
    h('button', { type: 'button', onclick: () => view.reset() }, 'Whole map'));
  canvas.width = DISPLAY_WIDTH_PX;
  canvas.height = DISPLAY_WIDTH_PX * 3 / 4;
  // The canvas keeps the map's aspect once the first map is known.
  const fitAspect = () => { if (map) canvas.height = Math.round(DISPLAY_WIDTH_PX * map.source_height / map.source_width); };
  const firstLoad = load().then(() => { fitAspect(); redrawView(); });
  section.append(h('div', { class: 'inline' }, field('Map', channel), loading), zoomButtons,
    h('div', { class: 'map-row' }, canvas, contrast.element), readout, region.element, message.element);
  section.ready = firstLoad;
  return section;
}
