// Live: every camera's preview (server-sent PreviewFrames), its 64-bin
// histogram and clipped-pixel overlay, the LED state and the cameras'
// exposure and pixel format, all settable from the page. The picture is
// white-balanced from the calibration (which library, or "none: raw", is
// shown); a region dragged on it (or typed) is where the histogram and the
// raw means come from.
import * as api from '../api.js';
import { h, field, messageArea, formatNumber, formatExposure, decodeBase64 } from '../dom.js';
import { histogramChart } from '../plot.js';

// Each LED type drawn in its own light's colour (the whites from cool to warm).
export const LED_COLOURS = { w57: '#6f8fc8', w40: '#a8a08a', w27: '#d9963f', red: '#d62728', green: '#2ca02c', blue: '#1f4fd6' };
export const LED_CHANNELS = [
  ['w57', 'W57 (cool white)'], ['w40', 'W40 (neutral white)'], ['w27', 'W27 (warm white)'],
  ['red', 'Red'], ['green', 'Green'], ['blue', 'Blue'],
];

// Draws one PreviewFrame: the JPEG onto `picture`, the clipped mask (one bit
// per preview pixel, row-major, LSB first) in red onto `overlay`.
async function drawFrame(frame, picture, overlay) {
  const bitmap = await createImageBitmap(new Blob([decodeBase64(frame.jpeg)], { type: 'image/jpeg' }));
  picture.width = overlay.width = frame.width;
  picture.height = overlay.height = frame.height;
  picture.getContext('2d').drawImage(bitmap, 0, 0);
  bitmap.close();
  const mask = decodeBase64(frame.clipped_mask);
  const context = overlay.getContext('2d');
  const image = context.createImageData(frame.width, frame.height);
  const pixels = frame.width * frame.height;
  for (let i = 0; i < pixels; ++i) {
    if (mask[i >> 3] & (1 << (i & 7))) {
      image.data[4 * i] = 255;
      image.data[4 * i + 3] = 200;
    }
  }
  context.putImageData(image, 0, 0);
}

// The newest succeeded session's Cm map of this camera (MapsService.GetMap,
// 480 cells wide): {id, map}, or null.
async function lastSessionMap(cameraName) {
  const { sessions = [] } = await api.call('SessionService', 'ListSessions', { limit: 20 });
  for (const session of sessions) {
    if (session.operation?.state !== 'OPERATION_STATE_SUCCEEDED') continue;
    const results = await api.call('ResultsService', 'GetResults', { session_id: session.id });
    const camera = (results.cameras ?? []).find((c) => c.camera === cameraName && c.state === 'RESULTS_STATE_AVAILABLE');
    if (!camera) continue;
    const map = await api.call('MapsService', 'GetMap', { session_id: session.id,
      maps_file: camera.maps_file.slice(results.folder.length + 1), channel: 'Cm', max_width: 480 });
    return { id: session.id, map };
  }
  return null;
}

// The ghost: the map's explained cells in translucent white over the picture
// (its outline is where the subject was), nothing where the map has no value.
function drawGhost(canvas, map) {
  canvas.width = map.width;
  canvas.height = map.height;
  const context = canvas.getContext('2d');
  const image = context.createImageData(map.width, map.height);
  map.values.forEach((raw, i) => {
    if (!Number.isFinite(Number(raw))) return;
    image.data.set([255, 255, 255, 90], 4 * i);
  });
  context.putImageData(image, 0, 0);
  canvas.dataset.cells = String(map.values.filter((raw) => Number.isFinite(Number(raw))).length);
}

// "10, 20, 30, 40" (per cent of the frame: x, y, width, height) → fractions,
// or an Error naming what is wrong; "" → null (the whole frame).
export function parseRegion(text) {
  if (!text.trim()) return null;
  const parts = text.split(',').map((part) => part.trim());
  const numbers = parts.map(Number);
  if (parts.length !== 4 || parts.some((part) => part === '') || numbers.some((n) => !Number.isFinite(n)))
    throw new Error(`Region: "${text}" is not four numbers x, y, width, height (per cent of the frame)`);
  const [x, y, width, height] = numbers;
  if (x < 0 || y < 0 || width <= 0 || height <= 0 || x + width > 100 || y + height > 100)
    throw new Error(`Region: ${text} does not lie inside the frame (x, y ≥ 0; width, height > 0; x + width and y + height ≤ 100)`);
  return { x: x / 100, y: y / 100, width: width / 100, height: height / 100 };
}

const percent = (fraction) => String(Math.round(fraction * 1000) / 10);

// The region's outline on its own canvas over the picture (preview pixels).
function drawRegion(canvas, frame) {
  canvas.width = frame.width;
  canvas.height = frame.height;
  const context = canvas.getContext('2d');
  context.clearRect(0, 0, canvas.width, canvas.height);
  if (frame.region_width === frame.width && frame.region_height === frame.height) return;
  context.strokeStyle = '#ffd400';
  context.lineWidth = 2;
  context.strokeRect(frame.region_x + 1, frame.region_y + 1, frame.region_width - 2, frame.region_height - 2);
}

function cameraPanel(camera) {
  const picture = h('canvas', { class: 'picture', 'aria-label': `${camera.name}: live picture`, role: 'img' });
  const overlay = h('canvas', { class: 'overlay', 'aria-hidden': 'true' });
  const showClipped = h('input', { type: 'checkbox', checked: true });
  // Zoom: the picture at 1, 2 or 4 times its box, scrolled inside it.
  const zoom = h('select', { name: 'zoom' }, [1, 2, 4].map((factor) => h('option', { value: String(factor) }, `${factor}×`)));
  const pictureFrame = h('div', { class: 'picture-zoom' });
  zoom.addEventListener('change', () => { pictureFrame.dataset.zoom = zoom.value; });
  // The last finished session's Cm map over the picture, to put the subject back where it was.
  const ghost = h('canvas', { class: 'ghost', 'aria-hidden': 'true', hidden: true });
  const showGhost = h('input', { type: 'checkbox' });
  const ghostNote = h('span', { class: 'muted' });
  showGhost.addEventListener('change', async () => {
    ghost.hidden = true;
    ghostNote.textContent = '';
    if (!showGhost.checked) return;
    try {
      const source = await lastSessionMap(camera.name);
      if (!source) { ghostNote.textContent = ' (no finished session with maps yet)'; return; }
      drawGhost(ghost, source.map);
      ghost.hidden = false;
      ghostNote.textContent = ` (session ${source.id})`;
    } catch (error) {
      ghostNote.textContent = ` (${error.message})`;
    }
  });
  showClipped.addEventListener('change', () => overlay.classList.toggle('hidden', !showClipped.checked));
  // White balance from the calibration, and the region of the histogram and means.
  const whiteBalance = h('input', { type: 'checkbox', checked: true, name: 'white_balance' });
  const balanceNote = h('p', { class: 'white-balance muted', 'aria-live': 'polite' });
  const regionCanvas = h('canvas', { class: 'region', 'aria-hidden': 'true' });
  const regionInput = h('input', { type: 'text', name: 'region', placeholder: 'whole frame', spellcheck: false });
  const regionMessage = messageArea();
  let region = null;
  const histogram = h('div', { class: 'live-histogram' });
  const facts = h('dl', { class: 'facts' });
  const exposure = h('input', { type: 'number', min: camera.exposure_min_us || 1, max: camera.exposure_max_us || 10000000,
    step: 'any', value: camera.exposure_us, required: true });
  const pixelFormat = h('select', {}, (camera.pixel_formats ?? []).map((format) =>
    h('option', { value: format, selected: format === camera.pixel_format }, format)));
  const message = messageArea();
  const form = h('form', { class: 'inline' },
    field('Exposure (µs)', exposure), field('Pixel format', pixelFormat),
    h('button', { type: 'submit' }, 'Apply camera settings'));
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    message.clear();
    try {
      const applied = await api.call('CameraService', 'SetCameraSettings',
        { camera: camera.name, exposure_us: Number(exposure.value), pixel_format: pixelFormat.value });
      message.info(`applied: exposure ${formatExposure(applied.exposure_us)}, ${applied.pixel_format}`);
    } catch (error) {
      message.error(error);
    }
  });
  pictureFrame.append(picture, overlay, ghost, regionCanvas);
  pictureFrame.dataset.zoom = '1';
  const frameCounter = { frames: 0 };
  const onFrame = async (frame) => {
    frameCounter.frames += 1;
    await drawFrame(frame, picture, overlay);
    picture.dataset.sequence = frame.sequence;
    picture.dataset.frames = frameCounter.frames;
    drawRegion(regionCanvas, frame);
    const bins = frame.histogram ?? [];
    const whole = frame.region_width === frame.width && frame.region_height === frame.height;
    histogram.replaceChildren(histogramChart(bins, Number(frame.full_scale ?? 0),
      { title: `${camera.name}: histogram of raw values ${whole ? '' : 'in the region '}(${bins.length} bins, square-root counts)` }));
    balanceNote.textContent = `White balance: ${frame.white_balance}`;
    balanceNote.dataset.gains = JSON.stringify(frame.white_balance_gains ?? []);
    const means = (frame.region_mean ?? []).map(Number);
    histogram.dataset.regionMean = JSON.stringify(means);
    histogram.dataset.regionCells = String(frame.region_cells ?? 0);
    histogram.dataset.samples = String(bins.reduce((sum, count) => sum + Number(count), 0));
    const rows = [
      ['Exposure', formatExposure(frame.exposure_us)], ['Pixel format', frame.pixel_format],
      ['Clipped pixels', `${frame.clipped_pixels} of ${frame.width * frame.height}`], ['Full scale', frame.full_scale],
      ['Source', frame.source], ['Frame', frame.sequence], ['Sensor', `${frame.source_width}×${frame.source_height}`],
      ['Region', whole ? `whole frame (${frame.region_cells} pixels)`
        : `${frame.region_width}×${frame.region_height} px at ${frame.region_x}, ${frame.region_y} (${frame.region_cells} pixels)`],
      ['Mean (raw)', means.length === 3 ? `R ${formatNumber(means[0], 4)}, G ${formatNumber(means[1], 4)}, B ${formatNumber(means[2], 4)}`
        : formatNumber(means[0] ?? 0, 4)],
    ];
    facts.replaceChildren(...rows.flatMap(([term, value]) => [h('dt', {}, term), h('dd', {}, String(value))]));
  };
  const streamMessage = messageArea();
  let closeStream = () => {};
  const openPreview = () => {
    closeStream();
    const query = new URLSearchParams({ camera: camera.name, rate_hz: '10', width: '480', white_balance: whiteBalance.checked ? '1' : '0' });
    if (region) query.set('region', [region.x, region.y, region.width, region.height].join(','));
    closeStream = api.openStream(`/api/stream/preview?${query}`,
      (frame) => { streamMessage.clear(); onFrame(frame); }, (failure) => streamMessage.error({ message: failure.error, code: failure.code }));
  };
  const setRegion = (next) => {
    region = next;
    regionInput.value = region ? [region.x, region.y, region.width, region.height].map(percent).join(', ') : '';
    openPreview();
  };
  regionInput.addEventListener('change', () => {
    regionMessage.clear();
    try {
      setRegion(parseRegion(regionInput.value));
    } catch (error) {
      regionMessage.error(error);  // the region shown stays the one in use
    }
  });
  whiteBalance.addEventListener('change', openPreview);
  // Drag a rectangle on the picture: its region in fractions of the frame.
  let dragStart = null;
  const fractionAt = (event) => {
    const box = picture.getBoundingClientRect();
    return { x: Math.min(1, Math.max(0, (event.clientX - box.left) / box.width)), y: Math.min(1, Math.max(0, (event.clientY - box.top) / box.height)) };
  };
  pictureFrame.addEventListener('pointerdown', (event) => {
    if (event.button !== 0 || event.shiftKey) return;
    dragStart = fractionAt(event);
    pictureFrame.setPointerCapture(event.pointerId);
    event.preventDefault();
  });
  pictureFrame.addEventListener('pointerup', (event) => {
    if (!dragStart) return;
    const end = fractionAt(event);
    const start = dragStart;
    dragStart = null;
    const width = Math.abs(end.x - start.x), height = Math.abs(end.y - start.y);
    if (width < 0.01 || height < 0.01) return;  // a click, not a drag
    regionMessage.clear();
    setRegion({ x: Math.min(start.x, end.x), y: Math.min(start.y, end.y), width, height });
  });
  const wholeFrame = h('button', { type: 'button' }, 'Whole frame');
  wholeFrame.addEventListener('click', () => { regionMessage.clear(); setRegion(null); });
  openPreview();
  const close = () => closeStream();
  const section = h('section', { class: 'camera card', 'aria-label': `Camera ${camera.name}` },
    h('h3', {}, `${camera.name}`, h('span', { class: 'muted' }, ` ${camera.vendor} ${camera.model} ${camera.sensor_width}×${camera.sensor_height}`)),
    camera.error ? h('p', { class: 'message error' }, camera.error) : null,
    h('div', { class: 'camera-body' },
      h('div', { class: 'picture-box' }, pictureFrame),
      h('div', { class: 'camera-side' },
        h('label', { class: 'check' }, showClipped, ' Show clipped pixels (red)'),
        h('label', { class: 'check' }, showGhost, ' Show the last session as a ghost', ghostNote),
        h('label', { class: 'check' }, whiteBalance, ' White balance from the calibration'), balanceNote,
        field('Zoom', zoom),
        h('div', { class: 'inline' }, field('Region (% of the frame: x, y, width, height; or drag on the picture)', regionInput), wholeFrame),
        regionMessage.element,
        histogram, facts)),
    streamMessage.element, form, message.element);
  return { section, close };
}

// "W57 41.2 °C, W40 40.8 °C, …": each temperature with its LED when there is one per LED type.
function temperaturesText(temperatures) {
  if (temperatures.length !== LED_CHANNELS.length) return `${temperatures.map((t) => formatNumber(t, 3)).join(', ')} °C`;
  return temperatures.map((t, i) => `${LED_CHANNELS[i][1].split(' ')[0]} ${formatNumber(t, 3)} °C`).join(', ');
}

// A drive level as its input shows it: the controller's quantised level
// (0.30000762951094834 for 0.3 at 16-bit PWM) to 4 decimals, "0.3".
export function driveInputValue(level) {
  return String(Number(Number(level ?? 0).toFixed(4)));
}

function ledPanel() {
  const inputs = Object.fromEntries(LED_CHANNELS.map(([key]) =>
    [key, h('input', { type: 'number', min: 0, max: 1, step: 0.01, value: 0, name: key })]));
  const enabled = h('input', { type: 'checkbox', name: 'output_enabled' });
  const status = h('p', { class: 'led-status', 'aria-live': 'polite' });
  const message = messageArea();
  let edited = false;
  for (const input of Object.values(inputs)) input.addEventListener('input', () => { edited = true; });
  const show = (led) => {
    const drive = led.applied?.drive ?? {};
    status.textContent = `${led.controller}: output ${led.output_enabled ? 'on' : 'off'}; ` +
      LED_CHANNELS.map(([key]) => `${key} ${formatNumber(drive[key] ?? 0, 3)}`).join(', ') +
      `; temperatures ${temperaturesText(led.temperature_c ?? [])}`;
    status.dataset.drive = JSON.stringify(drive);
    if (!edited) {
      for (const [key] of LED_CHANNELS) inputs[key].value = driveInputValue(drive[key]);
      enabled.checked = led.output_enabled;
    }
  };
  const refresh = async () => {
    try {
      show(await api.call('LedService', 'GetLedState', {}));
    } catch (error) {
      message.error(error);
    }
  };
  const form = h('form', { class: 'leds' },
    h('fieldset', {}, h('legend', {}, 'Drive levels (0–1)'),
      LED_CHANNELS.map(([key, label]) => field(label, inputs[key]))),
    h('label', { class: 'check' }, enabled, ' Output enabled'),
    h('button', { type: 'submit' }, 'Set LEDs'));
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    message.clear();
    const drive = Object.fromEntries(LED_CHANNELS.map(([key]) => [key, Number(inputs[key].value)]));
    try {
      const led = await api.call('LedService', 'SetLedState', { state: { drive }, output_enabled: enabled.checked });
      edited = false;
      show(led);
      message.info('LED state applied');
    } catch (error) {
      message.error(error);
    }
  });
  refresh();
  const timer = setInterval(refresh, 2000);
  const section = h('section', { class: 'card', 'aria-labelledby': 'leds-heading' },
    h('h3', { id: 'leds-heading' }, 'LED state'), status, form, message.element);
  return { section, close: () => clearInterval(timer) };
}

export function mountLive(container) {
  const cameras = h('div', { class: 'cameras' });
  const message = messageArea();
  const leds = ledPanel();
  const closers = [leds.close];
  container.append(h('h2', {}, 'Live'), message.element, h('div', { class: 'live' }, cameras, leds.section));
  api.call('CameraService', 'ListCameras', {}).then((reply) => {
    if (!reply.cameras?.length) message.info('No cameras configured.');
    for (const camera of reply.cameras ?? []) {
      const panel = cameraPanel(camera);
      closers.push(panel.close);
      cameras.append(panel.section);
    }
  }, (error) => message.error(error));
  return () => closers.forEach((close) => close());
}
