// Small DOM helpers: elements from tags and properties (no innerHTML, no
// inline styles: the page's Content-Security-Policy allows neither).

const SVG_NS = 'http://www.w3.org/2000/svg';

function append(parent, children) {
  for (const child of children.flat()) {
    if (child === null || child === undefined || child === false) continue;
    parent.append(child instanceof Node ? child : String(child));
  }
}

// h('button', {type: 'button', onclick: f, class: 'x'}, 'Text')
export function h(tag, properties = {}, ...children) {
  const element = document.createElement(tag);
  for (const [key, value] of Object.entries(properties)) {
    if (value === undefined || value === null || value === false) continue;
    if (key.startsWith('on')) element.addEventListener(key.slice(2), value);
    else if (key === 'class') element.className = value;
    else if (key in element && key !== 'list' && key !== 'form') element[key] = value;
    else element.setAttribute(key, value === true ? '' : value);
  }
  append(element, children);
  return element;
}

export function s(tag, attributes = {}, ...children) {
  const element = document.createElementNS(SVG_NS, tag);
  for (const [key, value] of Object.entries(attributes)) element.setAttribute(key, value);
  append(element, children);
  return element;
}

let uniqueCounter = 0;
export function uniqueId(prefix) {
  uniqueCounter += 1;
  return `${prefix}-${uniqueCounter}`;
}

// A labelled form control: <label for=id>text</label><control id=id>.
export function field(labelText, control) {
  if (!control.id) control.id = uniqueId('field');
  return h('div', { class: 'field' }, h('label', { htmlFor: control.id }, labelText), control);
}

// What went wrong, for an operator: the daemon's message without the gRPC
// code (FAILED_PRECONDITION and the like mean nothing at the sphere).
export function humanError(error) {
  return String(error?.message ?? error);
}

// A region that says what went wrong (role=alert) or what happened (status).
export function messageArea(name = '') {
  const base = `message ${name}`.trim();
  const area = h('p', { class: base, role: 'status', 'aria-live': 'polite' });
  return {
    element: area,
    error(error) {
      area.className = `${base} error`;
      area.textContent = humanError(error);
      if (error?.code) area.dataset.code = error.code;  // for scripts and tests, not shown
    },
    info(text) {
      area.className = `${base} info`;
      area.textContent = text;
    },
    clear() {
      area.className = base;
      area.textContent = '';
    },
  };
}

// A long identifier ("white_w57+blue", a path) may wrap after "_" and "/"
// (a <wbr>), never inside a word: the text, with those break points.
export function breakable(text) {
  const parts = String(text).split(/(?<=[_/])/);
  return parts.length === 1 ? parts[0] : parts.flatMap((part, i) => (i ? [h('wbr'), part] : [part]));
}

// A table; a text cell may wrap at its identifiers' "_" and "/" (breakable).
export function table(headers, rows, caption) {
  return h(
    'table',
    {},
    caption ? h('caption', {}, caption) : null,
    h('thead', {}, h('tr', {}, headers.map((header) => h('th', { scope: 'col' }, header)))),
    h('tbody', {}, rows.map((row) => h('tr', {}, row.map((cell) => h('td', {}, typeof cell === 'string' ? breakable(cell) : cell))))),
  );
}

// `digits` significant digits, written out as a person reads them: 9734.2 →
// "9730", 0.01234 → "0.0123"; the exponent form only below 0.001 or from 1e9.
export function formatNumber(value, digits = 3) {
  if (value === undefined || value === null || value === '') return '–';
  const number = Number(value);
  if (!Number.isFinite(number)) return String(value);
  if (Number.isInteger(number) && Math.abs(number) < 1e9) return String(number);
  const rounded = Number(number.toPrecision(digits));
  if (rounded !== 0 && (Math.abs(rounded) < 1e-3 || Math.abs(rounded) >= 1e9)) return number.toPrecision(digits);
  return String(rounded);
}

// An exposure as people read it: whole microseconds with thousands grouped
// ("9,730 µs" for 9734.2, never "9.73e+3 µs"); below 100 µs three digits.
export function formatExposure(exposureUs) {
  const us = Number(exposureUs);
  if (exposureUs === undefined || exposureUs === null || exposureUs === '' || !Number.isFinite(us)) return '–';
  if (Math.abs(us) < 100) return `${formatNumber(us, 3)} µs`;
  return `${Math.round(us).toLocaleString('en-US')} µs`;
}

// A duration for people: "12 min", "3.2 h", "4.0 days".
export function formatAge(seconds) {
  if (!(seconds >= 0)) return 'of unknown age';
  if (seconds < 3600) return `${Math.round(seconds / 60)} min`;
  if (seconds < 48 * 3600) return `${(seconds / 3600).toFixed(1)} h`;
  return `${(seconds / 86400).toFixed(1)} days`;
}

// "OPERATION_STATE_RUNNING" -> "running"
export function enumName(value, prefix) {
  return String(value ?? '').replace(prefix, '').toLowerCase().replaceAll('_', ' ');
}

// A light's polarisation: cross- or parallel-polarised need a sphere with
// polariser banks (docs/polarisation.md); the API may omit the default.
export function polarisationName(value) {
  return value ? enumName(value, 'POLARISATION_') : 'unpolarised';
}

export function decodeBase64(text) {
  const binary = atob(text ?? '');
  const bytes = new Uint8Array(binary.length);
  for (let i = 0; i < binary.length; ++i) bytes[i] = binary.charCodeAt(i);
  return bytes;
}
