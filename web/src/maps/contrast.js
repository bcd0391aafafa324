// A map's contrast: the presets (the subject's 1-99th percentile, the
// model's range, the map's min-max), the ends typed in, linear or log, the
// histogram of the skin's values inside the window, and the colour bar with
// round ticks and the unit; for codes (flags, order) a legend instead.
import { h, field, formatNumber } from '../dom.js';
import { viridis, position, ticks, percentileOfSorted, MASKED_COLOUR, OUTSIDE_COLOUR } from './colour_scale.js';
import { isCategorical, categoryColour } from './map_image.js';

const BAR_WIDTH = 320;
const HISTOGRAM_BINS = 64;
const ORDER_NAMES = { 0: 'none', 2: '2D model', 4: '4D model' };

function swatch(rgb, label) {
  const box = h('canvas', { class: 'swatch', width: 12, height: 12, 'aria-hidden': 'true' });
  const context = box.getContext('2d');
  context.fillStyle = `rgb(${rgb.join(',')})`;
  context.fillRect(0, 0, 12, 12);
  return h('li', {}, box, ` ${label}`);
}

// The contrast a preset gives for a loaded map ({model_min, model_max, log_scale, min, max}) and its skin sample.
export function presetContrast(preset, map, sorted) {
  if (preset === 'model' && map.model_max > 0)
    return { low: map.model_min, high: map.model_max, log: map.log_scale };
  if (preset === 'percentile' && sorted.length)
    return { low: percentileOfSorted(sorted, 1), high: percentileOfSorted(sorted, 99), log: false };
  return { low: map.min, high: map.max, log: false };
}

export function contrastControls(onChange) {
  const preset = h('select', {},
    h('option', { value: 'percentile' }, "subject's 1–99th percentile"),
    h('option', { value: 'model' }, "the model's range"),
    h('option', { value: 'range' }, 'min–max of the map'),
    h('option', { value: 'custom' }, 'custom'));
  const low = h('input', { type: 'number', step: 'any', class: 'contrast-end' });
  const high = h('input', { type: 'number', step: 'any', class: 'contrast-end' });
  const log = h('input', { type: 'checkbox' });
  const histogram = h('canvas', { class: 'histogram', width: BAR_WIDTH, height: 48, role: 'img' });
  const bar = h('canvas', { class: 'colour-bar', width: BAR_WIDTH, height: 34, role: 'img' });
  const title = h('span', { class: 'bar-title' });
  const legend = h('ul', { class: 'legend' });
  const scale = h('div', { class: 'contrast-scale' }, title, histogram, bar);
  let current = null;  // {map, sorted, contrast}

  const drawHistogram = () => {
    const { sorted, contrast } = current;
    const bins = new Array(HISTOGRAM_BINS).fill(0);
    let below = 0, above = 0;
    for (const v of sorted) {
      if (v < contrast.low) below += 1;
      else if (v > contrast.high) above += 1;
      else bins[Math.min(HISTOGRAM_BINS - 1, Math.floor(position(v, contrast) * HISTOGRAM_BINS))] += 1;
    }
    const context = histogram.getContext('2d');
    context.clearRect(0, 0, histogram.width, histogram.height);
    const top = Math.sqrt(Math.max(1, ...bins));
    const width = histogram.width / HISTOGRAM_BINS;
    bins.forEach((count, i) => {
      const height = Math.sqrt(count) / top * (histogram.height - 2);
      context.fillStyle = `rgb(${viridis((i + 0.5) / HISTOGRAM_BINS).join(',')})`;
      context.fillRect(i * width, histogram.height - height, Math.max(1, width - 1), height);
    });
    histogram.setAttribute('aria-label', `histogram of ${sorted.length} skin samples (square-root counts): ` +
      `${below} below the low end, ${above} above the high end`);
    histogram.dataset.below = String(below);
    histogram.dataset.above = String(above);
  };

  const drawBar = () => {
    const { map, contrast } = current;
    const context = bar.getContext('2d');
    context.clearRect(0, 0, bar.width, bar.height);
    for (let x = 0; x < bar.width; ++x) {
      context.fillStyle = `rgb(${viridis(x / (bar.width - 1)).join(',')})`;
      context.fillRect(x, 0, 1, 12);
    }
    context.fillStyle = '#1d2430';
    context.font = '10px sans-serif';
    const values = ticks(contrast);
    for (const v of values) {
      const x = Math.round(position(v, contrast) * (bar.width - 1));
      context.fillRect(x, 12, 1, 5);
      const text = formatNumber(v, 3);
      const textWidth = context.measureText(text).width;
      context.fillText(text, Math.min(Math.max(0, x - textWidth / 2), bar.width - textWidth), 28);
    }
    bar.dataset.ticks = values.join(' ');
    bar.setAttribute('aria-label', `colour bar ${contrast.log ? '(log scale) ' : ''}from ${formatNumber(contrast.low, 4)} to ` +
      `${formatNumber(contrast.high, 4)}${map.unit ? ` ${map.unit}` : ''}; ticks ${values.map((v) => formatNumber(v, 3)).join(', ')}`);
  };

  const drawLegend = (counts) => {
    const { map } = current;
    const items = [];
    if (isCategorical(map.channel)) {
      const codes = [...new Set(Array.from(map.values).filter(Number.isFinite).map(Math.round))].sort((a, b) => a - b);
      for (const code of codes) {
        const name = map.channel === 'flags' ? (map.flag_names[code] ?? `code ${code}`) : (ORDER_NAMES[code] ?? `order ${code}`);
        items.push(swatch(categoryColour(map.channel, code), `${code}: ${name}`));
      }
    } else {
      items.push(swatch(MASKED_COLOUR, `masked by a flag (${counts.masked} cells)`));
    }
    items.push(swatch(OUTSIDE_COLOUR, `outside the lit field or the skin: the white target (${counts.outside} cells)`));
    legend.replaceChildren(...items);
  };

  const apply = () => {
    const contrast = { low: Number(low.value), high: Number(high.value), log: log.checked };
    if (!(contrast.high > contrast.low) || (contrast.log && !(contrast.low > 0))) {
      low.setCustomValidity(contrast.log ? 'a log scale needs 0 < low < high' : 'low must be below high');
      low.reportValidity();
      return;
    }
    low.setCustomValidity('');
    current.contrast = contrast;
    onChange(contrast);
  };
  const setFields = (contrast) => {
    low.value = String(Number(contrast.low.toPrecision(6)));
    high.value = String(Number(contrast.high.toPrecision(6)));
    log.checked = contrast.log;
  };
  preset.addEventListener('change', () => {
    if (!current || preset.value === 'custom') return;
    setFields(presetContrast(preset.value, current.map, current.sorted));
    apply();
  });
  for (const input of [low, high, log]) input.addEventListener('change', () => { preset.value = 'custom'; if (current) apply(); });

  return {
    element: h('div', { class: 'contrast' },
      h('div', { class: 'inline' }, field('Contrast', preset), field('Low', low), field('High', high), field('Log scale', log)),
      scale, legend),
    // A newly loaded map: the chosen preset (custom keeps the typed ends when they fit the scale) and its scale.
    load(map, sorted) {
      const keep = preset.value === 'custom' && current && Number(high.value) > Number(low.value);
      current = { map, sorted, contrast: keep ? { low: Number(low.value), high: Number(high.value), log: log.checked }
        : presetContrast(preset.value, map, sorted) };
      setFields(current.contrast);
      title.textContent = `${map.channel}${map.unit ? ` (${map.unit})` : ''}`;
      for (const control of [preset, low, high, log]) control.disabled = isCategorical(map.channel);
      histogram.hidden = bar.hidden = isCategorical(map.channel);
      return current.contrast;
    },
    // Redraws the histogram, the colour bar and the legend for the contrast in use.
    draw(counts) {
      if (!current) return;
      if (!isCategorical(current.map.channel)) drawHistogram(), drawBar();
      drawLegend(counts);
    },
    get contrast() { return current?.contrast; },
  };
}
