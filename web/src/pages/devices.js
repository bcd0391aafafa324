// Devices and calibration: each device's health with the driver's error,
// starting an LED calibration and following it, and the mixes solved on the
// daemon's LED library (drive levels and figures of merit).
import * as api from '../api.js';
import { h, field, messageArea, table, enumName, humanError } from '../dom.js';
import { barChart, linePlot } from '../plot.js';
import { operationView } from '../operation.js';
import { LED_CHANNELS, LED_COLOURS } from './live.js';

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

// A mix's figures of merit as an operator reads them: name, value to the
// figure's useful resolution (never "1.001e-16": a Δu′v′ of 1e-16 is 0.00000), unit.
const FIGURES = {
  camera_de00_mean: ['camera ΔE00, mean over the chart', 2, ''], camera_de00_max: ['camera ΔE00, worst patch', 2, ''],
  cct_K: ['correlated colour temperature', 0, 'K'], delta_uv_prime: ['Δu′v′ from the target', 5, ''],
  ra: ['colour rendering index Ra', 1, ''], rmse: ['spectral RMSE', 4, 'library units/nm'],
};
function figuresTable(figures, caption) {
  const rows = Object.entries(figures).sort(([a], [b]) => a.localeCompare(b)).map(([name, value]) => {
    const [label, decimals, unit] = FIGURES[name] ?? [name, 4, ''];
    const text = Number(value).toLocaleString('en-US', { minimumFractionDigits: decimals, maximumFractionDigits: decimals });
    return h('tr', { 'data-figure': name, 'data-decimals': decimals }, h('td', {}, label), h('td', {}, unit ? `${text} ${unit}` : text));
  });
  return h('table', {}, h('caption', {}, caption),
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Figure of merit'), h('th', { scope: 'col' }, 'Value'))), h('tbody', {}, rows));
}

const LIBRARY_KEYS = { W57: 'w57', W40: 'w40', W27: 'w27', R: 'red', G: 'green', B: 'blue' };

// The mix's spectrum (Σ weight × spectrum per unit drive) against the target,
// D65 scaled to the mix's power (a D65' target); W57 mixes are shown alone.
function mixSpectrumPlot(library, weights, target, title) {
  const mix = library.wavelength_nm.map((_, i) => library.leds.reduce((sum, led) =>
    sum + (weights[LIBRARY_KEYS[led.led]] ?? 0) * led.spectrum_per_unit_drive[i], 0));
  const series = [{ name: 'mix', x: library.wavelength_nm, y: mix }];
  if (target === 'd65') {
    const mixPower = mix.reduce((a, b) => a + b, 0);
    const d65Power = library.d65.reduce((a, b) => a + b, 0);
    series.push({ name: 'target D65', x: library.wavelength_nm, y: library.d65.map((v) => (v * mixPower) / d65Power), dashed: true });
  }
  return linePlot(series, { title: `${title}: mix spectrum against its target`, xLabel: 'wavelength (nm)',
    yLabel: 'power (library units/nm)', width: 420, height: 200 });
}

function mixesSection() {
  const body = h('div', { class: 'mixes' });
  const spectra = h('div', { class: 'library' });
  const message = messageArea();
  const refresh = async () => {
    message.clear();
    body.replaceChildren();
    let library = null;
    try {
      library = await api.call('CalibrationService', 'GetLedLibrary', {});
      spectra.replaceChildren(
        linePlot(library.leds.map((led) => ({ name: led.led, x: library.wavelength_nm, y: led.spectrum_per_unit_drive,
          colour: LED_COLOURS[LIBRARY_KEYS[led.led]] })),
          { title: `LED library (${library.source}, ${library.created_utc}): spectrum per unit drive`, xLabel: 'wavelength (nm)',
            yLabel: 'power per unit drive (library units/nm)' }),
        h('p', { class: 'muted' }, `LED library ${library.library}: ` +
          library.leds.map((led) => `${led.led} ${led.description} (ladder ${led.drive_levels.join(', ')}; limit ${led.max_drive_level})`).join('; ')));
    } catch (error) {
      if (error.code === 'FAILED_PRECONDITION') {
        // No library: one sentence and the way out, not one refusal per mix.
        spectra.replaceChildren(h('p', { class: 'message warning', 'data-no-library': '' },
          'No LED calibration yet: sessions would use the configured mixes and the built-in nominal spectra, not this sphere\'s. ',
          h('button', { type: 'button', onclick: () => document.querySelector('.calibration-form input')?.focus() }, 'Calibrate now')));
        return;
      }
      spectra.replaceChildren(h('p', { class: 'message error' }, `LED library: ${humanError(error)}`));
    }
    for (const [target, title, objective, hold] of MIX_TARGETS) {
      try {
        const mix = await api.call('CalibrationService', 'SolveMix', { target, objective, hold_chromaticity: hold });
        const weights = mix.weights ?? {};
        body.append(h('figure', { class: 'mix', 'data-target': target },
          barChart(LED_CHANNELS.map(([key]) => ({ name: key, value: weights[key] ?? 0, colour: LED_COLOURS[key] })),
            { title: `${title}: drive levels`, yMax: 1 }),
          library ? mixSpectrumPlot(library, weights, target, title) : null,
          h('figcaption', {}, title, h('details', {}, h('summary', {}, 'How the solver got there'), mix.summary)),
          // W57 is its own target: its figures would measure it against itself.
          target === 'w57' ? h('p', { class: 'muted' }, 'W57 alone, the reference of W57 + blue: no figures of merit against itself.')
            : figuresTable(mix.figures ?? {}, `${title}: figures of merit`),
          h('p', { class: 'muted' }, `library: ${mix.library}`)));
      } catch (error) {
        body.append(h('p', { class: 'message error' }, `${title}: ${humanError(error)}`));
      }
    }
  };
  refresh();
  return { section: h('section', { class: 'card', 'aria-labelledby': 'mixes-heading' },
    h('h3', { id: 'mixes-heading' }, 'LED library and solved mixes'), spectra, body,
    h('button', { type: 'button', onclick: refresh }, 'Solve the mixes again'), message.element), refresh };
}

function calibrationSection(onCalibrated) {
  const levels = h('input', { type: 'text', placeholder: 'default ladder', inputMode: 'decimal' });
  const warmup = h('input', { type: 'number', min: 0, max: 600000, step: 1, value: 0 });
  const message = messageArea();
  const progress = operationView({ controls: true, onFinished: onCalibrated });
  const form = h('form', { class: 'inline calibration-form' },
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
