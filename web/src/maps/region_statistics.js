// A region's statistics (MapsService.GetRegionStatistics: computed by chromod
// from maps.exr at full resolution, the numbers `chromo maps stats` prints):
// the table, and the rows exported as CSV with the columns of
// maps/region_statistics.hpp.
import * as api from '../api.js';
import { h, table, formatNumber, messageArea } from '../dom.js';

const COLUMNS = ['channel', 'unit', 'x', 'y', 'width', 'height', 'region_pixels', 'pixels', 'flagged_pixels',
  'outside_field_pixels', 'mean', 'sd', 'min', 'p1', 'p5', 'p25', 'median', 'p75', 'p95', 'p99', 'max'];

export function statisticsCsv(rows) {
  const line = (s) => COLUMNS.map((column) => (column in s.region ? s.region[column] : s[column])).join(',');
  return `${COLUMNS.join(',')}\n${rows.map(line).join('\n')}\n`;
}

export function regionStatisticsPanel(sessionId, mapsFile, cameraName) {
  const body = h('div', { class: 'region-statistics', 'aria-live': 'polite' },
    h('p', {}, 'Drag on the map (or type a region below) for the statistics of a region.'));
  const message = messageArea();
  const x = h('input', { type: 'number', min: 0, step: 1, class: 'region-field' });
  const y = h('input', { type: 'number', min: 0, step: 1, class: 'region-field' });
  const width = h('input', { type: 'number', min: 1, step: 1, class: 'region-field' });
  const height = h('input', { type: 'number', min: 1, step: 1, class: 'region-field' });
  const form = h('form', { class: 'inline region-form' },
    ...[['x (px)', x], ['y (px)', y], ['width (px)', width], ['height (px)', height]].map(([label, input]) =>
      h('div', { class: 'field' }, h('label', {}, label, input))),
    h('button', { type: 'submit' }, 'Region statistics'));
  let rows = [];
  const exportButton = h('button', { type: 'button', disabled: true }, 'Export CSV');
  exportButton.addEventListener('click', () => {
    const link = h('a', { href: URL.createObjectURL(new Blob([statisticsCsv(rows)], { type: 'text/csv' })),
      download: `${sessionId}-${cameraName || 'camera'}-region.csv` });
    document.body.append(link);
    link.click();
    link.remove();
    setTimeout(() => URL.revokeObjectURL(link.href), 1000);
  });
  let generation = 0;
  return {
    element: h('div', { class: 'region-panel' }, form, body, exportButton, message.element),
    form,
    // The region typed in, in map pixels, or null.
    typed() {
      const values = [x, y, width, height].map((input) => Number(input.value));
      return [x, y, width, height].every((input) => input.value !== '') ? { x: values[0], y: values[1], width: values[2], height: values[3] } : null;
    },
    // Asks chromod for `channel` in `region` (map pixels); a reply to an older question is dropped.
    async show(channel, region) {
      [x.value, y.value, width.value, height.value] = [region.x, region.y, region.width, region.height].map(String);
      const mine = ++generation;
      body.dataset.state = 'loading';
      body.replaceChildren(h('p', { class: 'loading' }, `computing ${channel} in the region…`));
      message.clear();
      try {
        const s = await api.call('MapsService', 'GetRegionStatistics', { session_id: sessionId, maps_file: mapsFile, channel, region });
        if (mine !== generation) return;
        rows = [s];
        const unit = s.unit ? ` (${s.unit})` : '';
        body.replaceChildren(
          h('p', {}, `${s.channel}${unit} in ${s.region.width}×${s.region.height} px at (${s.region.x}, ${s.region.y}): ` +
            `${s.pixels} skin pixels counted, ${s.flagged_pixels} masked by a flag, ${s.outside_field_pixels} outside the lit field.`),
          table(['Mean', 'SD', 'p1', 'p5', 'p25', 'Median', 'p75', 'p95', 'p99', 'Min', 'Max', 'Pixels'],
            [[s.mean, s.sd, s.p1, s.p5, s.p25, s.median, s.p75, s.p95, s.p99, s.min, s.max].map((v) => formatNumber(v, 5)).concat([s.pixels])],
            `${cameraName}: ${s.channel} in the region`));
        body.dataset.statistics = JSON.stringify(s);
        body.dataset.channel = s.channel;
        body.dataset.state = 'ready';
        exportButton.disabled = false;
      } catch (error) {
        if (mine !== generation) return;
        body.replaceChildren();
        body.dataset.state = 'error';
        message.error(error);
      }
    },
  };
}
