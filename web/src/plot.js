// SVG charts: line plots (spectra) and bar charts (histogram, drive levels).
// Sizes in SVG user units; the CSS scales them to their box.
import { s, formatNumber } from './dom.js';

const PALETTE = ['#4e79a7', '#f28e2b', '#e15759', '#76b7b2', '#59a14f', '#edc948', '#b07aa1', '#ff9da7', '#9c755f'];

export function colourOf(index) {
  return PALETTE[index % PALETTE.length];
}

// series: [{name, x: [...], y: [...], dashed}] → an <svg> with axes and a legend.
export function linePlot(series, { width = 560, height = 260, xLabel = '', yLabel = '', title = '' } = {}) {
  const margin = { left: 52, right: 120, top: 12, bottom: 36 };
  const xs = series.flatMap((line) => line.x);
  const ys = series.flatMap((line) => line.y);
  const xMin = Math.min(...xs), xMax = Math.max(...xs);
  const yMin = Math.min(0, ...ys), yMax = Math.max(...ys) || 1;
  const px = (x) => margin.left + ((x - xMin) / (xMax - xMin || 1)) * (width - margin.left - margin.right);
  const py = (y) => height - margin.bottom - ((y - yMin) / (yMax - yMin || 1)) * (height - margin.top - margin.bottom);
  const svg = s('svg', { viewBox: `0 0 ${width} ${height}`, role: 'img', 'aria-label': title || yLabel, class: 'chart' });
  svg.append(s('title', {}, title || yLabel));
  svg.append(s('line', { x1: margin.left, y1: py(yMin), x2: width - margin.right, y2: py(yMin), class: 'axis' }));
  svg.append(s('line', { x1: margin.left, y1: margin.top, x2: margin.left, y2: height - margin.bottom, class: 'axis' }));
  for (let i = 0; i <= 4; ++i) {
    const x = xMin + ((xMax - xMin) * i) / 4, y = yMin + ((yMax - yMin) * i) / 4;
    svg.append(s('text', { x: px(x), y: height - margin.bottom + 14, class: 'tick', 'text-anchor': 'middle' }, formatNumber(x, 3)));
    svg.append(s('text', { x: margin.left - 4, y: py(y) + 4, class: 'tick', 'text-anchor': 'end' }, formatNumber(y, 2)));
  }
  svg.append(s('text', { x: (width - margin.right + margin.left) / 2, y: height - 4, class: 'label', 'text-anchor': 'middle' }, xLabel));
  if (yLabel) {
    const yMiddle = (height - margin.bottom + margin.top) / 2;
    svg.append(s('text', { x: 10, y: yMiddle, class: 'label', 'text-anchor': 'middle', transform: `rotate(-90 10 ${yMiddle})` }, yLabel));
  }
  series.forEach((line, index) => {
    const points = line.x.map((x, i) => `${px(x).toFixed(1)},${py(line.y[i]).toFixed(1)}`).join(' ');
    const colour = line.colour ?? colourOf(index);  // a series may bring its own (an LED's colour)
    svg.append(s('polyline', { points, fill: 'none', stroke: colour, 'stroke-width': 1.6,
      'stroke-dasharray': line.dashed ? '5 3' : 'none' }));
    svg.append(s('text', { x: width - margin.right + 8, y: margin.top + 12 + 14 * index, fill: colour, class: 'legend' }, line.name));
  });
  return svg;
}

// bars: [{name, value}] → vertical bar chart.
export function barChart(bars, { width = 360, height = 140, title = '', yMax = null, colour = '#4e79a7', labels = true } = {}) {
  const margin = { left: 8, right: 8, top: 8, bottom: labels ? 22 : 8 };
  const top = yMax ?? Math.max(1e-12, ...bars.map((bar) => bar.value));
  const barWidth = (width - margin.left - margin.right) / Math.max(1, bars.length);
  const svg = s('svg', { viewBox: `0 0 ${width} ${height}`, role: 'img', 'aria-label': title, class: 'chart' });
  svg.append(s('title', {}, title));
  bars.forEach((bar, i) => {
    const barHeight = (Math.min(bar.value, top) / top) * (height - margin.top - margin.bottom);
    svg.append(s('rect', { x: margin.left + i * barWidth + 0.5, y: height - margin.bottom - barHeight,
      width: Math.max(0.5, barWidth - 1), height: barHeight, fill: bar.colour ?? colour }));
    if (labels) svg.append(s('text', { x: margin.left + (i + 0.5) * barWidth, y: height - 6, class: 'tick', 'text-anchor': 'middle' }, bar.name));
  });
  return svg;
}

// A camera's histogram of raw values with its axes (issue 41): `bins` counts
// over [0, fullScale], drawn as square-root counts; x ticks at 0, ¼, ½, ¾ and
// full scale in raw units, the last bin (full scale: clipped) in red.
export function histogramChart(bins, fullScale, { width = 360, height = 150, title = '' } = {}) {
  const margin = { left: 34, right: 8, top: 8, bottom: 32 };
  const plotWidth = width - margin.left - margin.right, plotHeight = height - margin.top - margin.bottom;
  const top = Math.max(1, ...bins.map((count) => Math.sqrt(count)));
  const svg = s('svg', { viewBox: `0 0 ${width} ${height}`, role: 'img', 'aria-label': title, class: 'chart histogram-chart' });
  svg.append(s('title', {}, title));
  const barWidth = plotWidth / Math.max(1, bins.length);
  bins.forEach((count, i) => {
    const barHeight = (Math.sqrt(count) / top) * plotHeight;
    svg.append(s('rect', { x: margin.left + i * barWidth, y: margin.top + plotHeight - barHeight, width: Math.max(0.5, barWidth - 0.5),
      height: barHeight, fill: i === bins.length - 1 ? '#e15759' : '#4e79a7' }));
  });
  svg.append(s('line', { x1: margin.left, y1: margin.top + plotHeight, x2: width - margin.right, y2: margin.top + plotHeight, class: 'axis' }));
  svg.append(s('line', { x1: margin.left, y1: margin.top, x2: margin.left, y2: margin.top + plotHeight, class: 'axis' }));
  for (let i = 0; i <= 4; ++i) {
    const x = margin.left + (plotWidth * i) / 4;
    svg.append(s('text', { x, y: margin.top + plotHeight + 12, class: 'tick', 'text-anchor': i === 0 ? 'start' : i === 4 ? 'end' : 'middle' },
      formatNumber(Math.round((fullScale * i) / 4))));
  }
  svg.append(s('text', { x: margin.left - 4, y: margin.top + 8, class: 'tick', 'text-anchor': 'end' }, formatNumber(Math.round(top * top))));
  svg.append(s('text', { x: margin.left - 4, y: margin.top + plotHeight, class: 'tick', 'text-anchor': 'end' }, '0'));
  svg.append(s('text', { x: margin.left + plotWidth / 2, y: height - 4, class: 'label', 'text-anchor': 'middle' },
    'raw value (last bin: full scale, clipped)'));
  const yMiddle = margin.top + plotHeight / 2;
  svg.append(s('text', { x: 9, y: yMiddle, class: 'label', 'text-anchor': 'middle', transform: `rotate(-90 9 ${yMiddle})` }, 'pixels (√)'));
  return svg;
}
