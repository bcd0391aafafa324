// A session's provenance (sessions.proto SessionProvenance): the LED library
// that lit it and its age, the mixes' drive levels, the camera
// sensitivities, the plan, the operator and study, the estimator's version
// and options: a card the Results page shows for every session.
import { h, table, formatNumber, formatAge } from './dom.js';

const LEVELS = [['w57', 'W57'], ['w40', 'W40'], ['w27', 'W27'], ['red', 'R'], ['green', 'G'], ['blue', 'B']];

function libraryText(library, now) {
  if (!library || library.kind === 'nominal')
    return 'the built-in nominal library: no calibration of this sphere was used (datasheet-class spectra)';
  const measured = library.created_utc ? Date.parse(library.created_utc) : NaN;
  const parts = [`measured ${library.created_utc || 'at an unknown time'}`];
  if (library.age_at_start_s !== undefined && library.age_at_start_s >= 0) parts.push(`${formatAge(library.age_at_start_s)} before the session`);
  if (Number.isFinite(measured)) parts.push(`${formatAge((now - measured) / 1000)} old now`);
  return `${parts.join(', ')}${library.file ? ` — ${library.file}` : ''}`;
}

// provenance: the API's SessionProvenance (may be absent for an older session).
export function provenanceCard(provenance, now = Date.now()) {
  const card = h('section', { class: 'card provenance', 'aria-labelledby': 'provenance-heading' },
    h('h3', { id: 'provenance-heading' }, 'Made with'));
  if (!provenance?.recorded) {
    card.dataset.recorded = 'false';
    card.append(h('p', {}, 'Not recorded: this session was made by an older chromod.'));
    return card;
  }
  const library = provenance.led_library ?? {};
  card.dataset.recorded = 'true';
  card.dataset.ledLibrary = library.kind ?? 'nominal';
  const options = Object.entries(provenance.estimator_options ?? {}).map(([key, value]) => `${key} ${value || '–'}`).join(', ');
  const cameras = [provenance.camera_sensitivity, ...Object.entries(provenance.camera_sensitivity_of ?? {})
    .map(([camera, source]) => `${camera}: ${source}`)].filter(Boolean).join('; ');
  card.append(
    h('dl', { class: 'facts' },
      h('dt', {}, 'LED library'), h('dd', { class: library.kind === 'measured' ? 'library' : 'library warning' }, libraryText(library, now)),
      h('dt', {}, 'Plan'), h('dd', {}, provenance.plan || '–'),
      h('dt', {}, 'Operator'), h('dd', { class: 'operator' }, provenance.operator_name || 'not given'),
      h('dt', {}, 'Study'), h('dd', {}, provenance.study || 'not given'),
      h('dt', {}, 'Camera sensitivity'), h('dd', {}, cameras || '–'),
      h('dt', {}, 'White reference ρ'), h('dd', {}, formatNumber(provenance.white_reflectance)),
      h('dt', {}, 'Estimator'), h('dd', { class: 'estimator' }, `${provenance.estimator_version || '–'}${options ? ` (${options})` : ''}`)),
    table(['Mix', ...LEVELS.map(([, name]) => name), 'From'],
      Object.entries(provenance.mixes ?? {}).sort(([a], [b]) => a.localeCompare(b)).map(([name, mix]) =>
        [name, ...LEVELS.map(([key]) => formatNumber(mix.weights?.[key] ?? 0)), mix.origin]),
      'Drive levels of the mixes (0–1 per LED type)'));
  return card;
}
