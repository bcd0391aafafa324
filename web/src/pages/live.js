// Live: every camera's preview (server-sent PreviewFrames), its 64-bin
// histogram and clipped-pixel overlay, the LED state and the cameras'
// exposure and pixel format, all settable from the page.
import * as api from '../api.js';
import { h, field, messageArea, formatNumber, decodeBase64 } from '../dom.js';
import { barChart } from '../plot.js';

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

function cameraPanel(camera) {
  const picture = h('canvas', { class: 'picture', 'aria-label': `${camera.name}: live picture`, role: 'img' });
  const overlay = h('canvas', { class: 'overlay', 'aria-hidden': 'true' });
  const showClipped = h('input', { type: 'checkbox', checked: true });
  showClipped.addEventListener('change', () => overlay.classList.toggle('hidden', !showClipped.checked));
  const histogram = h('div', { class: 'histogram' });
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
      message.info(`applied: exposure ${formatNumber(applied.exposure_us)} µs, ${applied.pixel_format}`);
    } catch (error) {
      message.error(error);
    }
  });
  const frameCounter = { frames: 0 };
  const onFrame = async (frame) => {
    frameCounter.frames += 1;
    await drawFrame(frame, picture, overlay);
    picture.dataset.sequence = frame.sequence;
    picture.dataset.frames = frameCounter.frames;
    const bins = frame.histogram ?? [];
    histogram.replaceChildren(barChart(bins.map((count, i) => ({ name: '', value: Math.sqrt(count),
      colour: i === bins.length - 1 ? '#e15759' : '#4e79a7' })), { title: `${camera.name}: histogram of raw values (64 bins, square-root counts)`, labels: false }));
    const rows = [
      ['Exposure', `${formatNumber(frame.exposure_us)} µs`], ['Pixel format', frame.pixel_format],
      ['Clipped pixels', `${frame.clipped_pixels} of ${frame.width * frame.height}`], ['Full scale', frame.full_scale],
      ['Source', frame.source], ['Frame', frame.sequence], ['Sensor', `${frame.source_width}×${frame.source_height}`],
    ];
    facts.replaceChildren(...rows.flatMap(([term, value]) => [h('dt', {}, term), h('dd', {}, String(value))]));
  };
  const streamMessage = messageArea();
  const close = api.openStream(`/api/stream/preview?camera=${encodeURIComponent(camera.name)}&rate_hz=10&width=480`,
    (frame) => { streamMessage.clear(); onFrame(frame); }, (failure) => streamMessage.error({ message: failure.error, code: failure.code }));
  const section = h('section', { class: 'camera card', 'aria-label': `Camera ${camera.name}` },
    h('h3', {}, `${camera.name}`, h('span', { class: 'muted' }, ` ${camera.vendor} ${camera.model} ${camera.sensor_width}×${camera.sensor_height}`)),
    camera.error ? h('p', { class: 'message error' }, camera.error) : null,
    h('div', { class: 'camera-body' },
      h('div', { class: 'picture-box' }, picture, overlay),
      h('div', { class: 'camera-side' },
        h('label', { class: 'check' }, showClipped, ' Show clipped pixels (red)'),
        histogram, facts)),
    streamMessage.element, form, message.element);
  return { section, close };
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
      `; temperatures ${(led.temperature_c ?? []).map((t) => formatNumber(t, 3)).join(', ')} °C`;
    status.dataset.drive = JSON.stringify(drive);
    if (!edited) {
      for (const [key] of LED_CHANNELS) inputs[key].value = drive[key] ?? 0;
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
