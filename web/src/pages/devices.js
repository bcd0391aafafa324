// Devices and calibration: each device's health with the driver's error,
// starting an LED calibration and following it, and the mixes solved on the
// daemon's LED library (drive levels and figures of merit).
import * as api from '../api.js';
import { h, field, messageArea, table, enumName, formatNumber } from '../dom.js';
import { barChart, colourOf } from '../plot.js';
import { operationView } from '../operation.js';
import { LED_CHANNELS } from './live.js';

const MIX_TARGETS = [['d65', "D65' (camera objective)", 'MIX_OBJECTIVE_CAMERA', true],
  ['w57', 'W57', 'MIX_OBJECTIVE_CAMERA', false], ['w57+blue', 'W57 + blue', 'MIX_OBJECTIVE_CAMERA', false]];

function devicesSection() {
  const body = h('div', {});
  const message = messageArea();
  const refresh = async () => {
    message.clear();
    try {
      const { devices = [] } = await api.call('DeviceService', 'ListDevices', {});
      body.replaceChildren(table(['Name', 'Kind', 'Backend', 'Address', 'Health', 'Error or fault', 'Info'],
        devices.map((device) => [device.name, enumName(device.kind, 'DEVICE_KIND_'), device.backend, device.address,
          h('span', { class: `health ${enumName(device.health, 'DEVICE_HEALTH_')}` }, enumName(device.health, 'DEVICE_HEALTH_')),
          device.detail || '–', Object.entries(device.info ?? {}).map(([k, v]) => `${k}: ${v}`).join('; ')]),
        'Devices'));
    } catch (error) {
      message.error(error);
    }
  };
  refresh();
  return h('section', { class: 'card', 'aria-labelledby': 'devices-heading' },
    h('h3', { id: 'devices-heading' }, 'Devices'), body,
    h('button', { type: 'button', onclick: refresh }, 'Refresh devices'), message.element);
}

function mixesSection() {
  const body = h('div', { class: 'mixes' });
  const message = messageArea();
  const refresh = async () => {
    message.clear();
    body.replaceChildren();
    for (const [target, title, objective, hold] of MIX_TARGETS) {
      try {
        const mix = await api.call('CalibrationService', 'SolveMix', { target, objective, hold_chromaticity: hold });
        const weights = mix.weights ?? {};
        const figures = Object.entries(mix.figures ?? {}).sort(([a], [b]) => a.localeCompare(b));
        body.append(h('figure', { class: 'mix', 'data-target': target },
          barChart(LED_CHANNELS.map(([key], i) => ({ name: key, value: weights[key] ?? 0, colour: colourOf(i) })),
            { title: `${title}: drive levels`, yMax: 1 }),
          h('figcaption', {}, `${title}: ${mix.summary}`),
          table(['Figure of merit', 'Value'], figures.map(([name, value]) => [name, formatNumber(value, 4)]), `${title}: figures of merit`),
          h('p', { class: 'muted' }, `library: ${mix.library}`)));
      } catch (error) {
        body.append(h('p', { class: 'message error' }, `${title}: ${error.message} (${error.code})`));
      }
    }
  };
  refresh();
  return { section: h('section', { class: 'card', 'aria-labelledby': 'mixes-heading' },
    h('h3', { id: 'mixes-heading' }, 'Solved mixes'), body,
    h('button', { type: 'button', onclick: refresh }, 'Solve the mixes again'), message.element), refresh };
}

function calibrationSection(onCalibrated) {
  const levels = h('input', { type: 'text', placeholder: 'default ladder', inputMode: 'decimal' });
  const warmup = h('input', { type: 'number', min: 0, max: 600000, step: 1, value: 0 });
  const message = messageArea();
  const progress = operationView({ controls: true, onFinished: onCalibrated });
  const form = h('form', { class: 'inline' },
    field('Drive levels (comma-separated, each in (0, 1])', levels), field('Warm-up (ms)', warmup),
    h('button', { type: 'submit' }, 'Start calibration'));
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    message.clear();
    const driveLevels = levels.value.split(',').map((text) => text.trim()).filter(Boolean).map(Number);
    if (driveLevels.some((level) => !(level > 0 && level <= 1))) {
      message.error({ message: `drive levels: each must be in (0, 1], got "${levels.value}"` });
      return;
    }
    try {
      progress.follow(await api.call('CalibrationService', 'StartCalibration',
        { drive_levels: driveLevels, warmup_ms: Number(warmup.value) }));
    } catch (error) {
      message.error(error);
    }
  });
  return { section: h('section', { class: 'card', 'aria-labelledby': 'calibration-heading' },
    h('h3', { id: 'calibration-heading' }, 'LED calibration'),
    h('p', {}, 'Measures every LED type with the spectrometer at each drive level and stores the LED library.'),
    form, message.element, progress.element), close: progress.close };
}

export function mountDevices(container) {
  const mixes = mixesSection();
  const calibration = calibrationSection(() => mixes.refresh());
  container.append(h('h2', {}, 'Devices and calibration'), devicesSection(), calibration.section, mixes.section);
  return () => calibration.close();
}
