// One map of a session's maps.exr drawn with its colour bar, and the value
// under the cursor (MapsService.GetMap: each cell is the map's value at the
// cell's centre, so a value shown is a value the map holds). The canvas takes
// the keyboard too: arrow keys move the cursor, the value follows.
import * as api from './api.js';
import { h, field, messageArea, formatNumber } from './dom.js';

// Viridis, sampled at five stops and interpolated linearly.
const STOPS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];

function colour(t) {
  const x = Math.min(Math.max(t, 0), 1) * (STOPS.length - 1);
  const i = Math.min(Math.floor(x), STOPS.length - 2);
  const f = x - i;
  return STOPS[i].map((a, k) => Math.round(a + (STOPS[i + 1][k] - a) * f));
}

function draw(canvas, map) {
  canvas.width = map.width;
  canvas.height = map.height;
  const context = canvas.getContext('2d');
  const image = context.createImageData(map.width, map.height);
  const span = map.max > map.min ? map.max - map.min : 1;
  map.values.forEach((raw, i) => {
    const v = Number(raw);  // protobuf JSON writes NaN as the string "NaN"
    const [r, g, b] = Number.isFinite(v) ? colour((v - map.min) / span) : [255, 255, 255];
    image.data.set([r, g, b, 255], 4 * i);
  });
  context.putImageData(image, 0, 0);
}

function colourBar(map) {
  const bar = h('canvas', { class: 'colour-bar', width: 256, height: 12, 'aria-hidden': 'true' });
  const context = bar.getContext('2d');
  for (let x = 0; x < 256; ++x) {
    const [r, g, b] = colour(x / 255);
    context.fillStyle = `rgb(${r},${g},${b})`;
    context.fillRect(x, 0, 1, 12);
  }
  return h('div', { class: 'colour-bar-row' }, h('span', {}, formatNumber(map.min, 4)), bar, h('span', {}, formatNumber(map.max, 4)));
}

export function mapExplorer(sessionId, mapsFile, cameraName) {
  const channel = h('select', {}, ['Cm', 'Ch', 'Bm', 'Che', 'residual', 'order', 'flags'].map((name) => h('option', { value: name }, name)));
  const canvas = h('canvas', { class: 'map-canvas', tabindex: 0, 'aria-label': `${cameraName} map; arrow keys move the cursor` });
  const readout = h('output', { class: 'map-value', 'aria-live': 'polite' }, 'point at the map for its value');
  const bar = h('div', {});
  const message = messageArea();
  let map = null;
  let cursor = { x: 0, y: 0 };
  const show = () => {
    if (!map) return;
    const raw = map.values[cursor.y * map.width + cursor.x];
    const v = Number(raw);
    const sourceX = Math.floor((cursor.x + 0.5) * map.source_width / map.width);
    const sourceY = Math.floor((cursor.y + 0.5) * map.source_height / map.height);
    readout.textContent = `${channel.value} at pixel (${sourceX}, ${sourceY}): ${Number.isFinite(v) ? formatNumber(v, 5) : 'no value'}`;
    readout.dataset.value = String(raw);
  };
  const load = async () => {
    message.clear();
    try {
      map = await api.call('MapsService', 'GetMap', { session_id: sessionId, maps_file: mapsFile, channel: channel.value, max_width: 480 });
      draw(canvas, map);
      bar.replaceChildren(colourBar(map));
      canvas.dataset.channel = channel.value;
      show();
    } catch (error) {
      message.error(error);
    }
  };
  canvas.addEventListener('mousemove', (event) => {
    if (!map) return;
    const box = canvas.getBoundingClientRect();
    cursor = { x: Math.min(map.width - 1, Math.floor((event.clientX - box.left) * map.width / box.width)),
               y: Math.min(map.height - 1, Math.floor((event.clientY - box.top) * map.height / box.height)) };
    show();
  });
  canvas.addEventListener('keydown', (event) => {
    if (!map) return;
    const step = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1] }[event.key];
    if (!step) return;
    event.preventDefault();
    cursor = { x: Math.min(map.width - 1, Math.max(0, cursor.x + step[0])), y: Math.min(map.height - 1, Math.max(0, cursor.y + step[1])) };
    show();
  });
  channel.addEventListener('change', load);
  load();
  return h('section', { class: 'map-explorer', 'aria-label': `${cameraName}: map with the value under the cursor` },
    field('Map', channel), canvas, bar, readout, message.element);
}
