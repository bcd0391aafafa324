// The preflight before a session (issue 41): the lab's checks
// (DeviceService.CheckLab, the ones `chromo doctor` prints: devices,
// permissions, cameras' receive buffers and networks, disk, clock, LED
// calibration, LED temperatures settled) as a checklist the operator sees before Start. A failed check
// stops the start unless the operator writes why to go on anyway: chromod
// keeps that reason, and the checks, in its audit log.
import * as api from './api.js';
import { h, field, humanError } from './dom.js';

const STATUS_WORDS = { CHECK_STATUS_OK: 'ok', CHECK_STATUS_WARNING: 'warning', CHECK_STATUS_FAILED: 'failed', CHECK_STATUS_SKIPPED: 'not checked' };

// "receive_buffer.cam0" → "Camera cam0: receive buffer"
function checkName(id) {
  const [kind, name] = id.split(/\.(.*)/s);
  const words = { device: `Device ${name}`, permissions: `Access to ${name}`, receive_buffer: `Camera ${name}: receive buffer`,
    mtu: `Camera ${name}: network`, disk: 'Disk space', clock: 'Clock', calibration: 'LED calibration', leds_settled: `LEDs settled (${name})` };
  return words[kind] ?? id;
}

// Returns {element, refresh(), request(): the StartSession fields, or throws an Error saying what is missing}.
export function preflightChecklist() {
  const list = h('ul', { class: 'checklist', 'aria-label': 'Checks before the session' });
  const reason = h('input', { type: 'text', maxLength: 4096, name: 'preflight_override_reason', spellcheck: true });
  const reasonField = field('A check failed: start anyway because (kept in the audit log)', reason);
  const status = h('p', { class: 'muted' });
  let failed = [];
  const refresh = async () => {
    status.textContent = 'checking the lab…';
    try {
      const { checks = [] } = await api.call('DeviceService', 'CheckLab', {});
      failed = checks.filter((check) => check.status === 'CHECK_STATUS_FAILED');
      const warnings = checks.filter((check) => check.status === 'CHECK_STATUS_WARNING');
      list.replaceChildren(...checks.map((check) => h('li', { class: `check ${STATUS_WORDS[check.status] ?? ''}`, 'data-check': check.id },
        h('strong', {}, `${checkName(check.id)}: ${STATUS_WORDS[check.status] ?? check.status}`), ` — ${check.finding}`,
        check.fix ? h('span', { class: 'fix' }, ` Fix: ${check.fix}`) : null,
        check.id === 'calibration' && check.status !== 'CHECK_STATUS_OK'
          ? h('a', { class: 'button', href: '#devices' }, 'Calibrate on the Devices page') : null)));
      status.textContent = failed.length ? `${failed.length} check(s) failed: fix them, or say why to start anyway.`
        : warnings.length ? `Ready, with ${warnings.length} warning(s).` : 'Ready: every check passed.';
      element.dataset.failed = String(failed.length);
      element.dataset.warnings = String(warnings.length);
    } catch (error) {
      status.textContent = `The checks could not run: ${humanError(error)}`;
    }
    reasonField.hidden = failed.length === 0;
  };
  const element = h('div', { class: 'preflight' }, h('h4', {}, 'Before you start'), status, list, reasonField,
    h('button', { type: 'button', onclick: refresh }, 'Check again'));
  reasonField.hidden = true;
  refresh();
  return {
    element,
    refresh,
    request() {
      if (failed.length && !reason.value.trim())
        throw new Error(`${failed.map((check) => checkName(check.id)).join(', ')} failed: fix it, or write why to start anyway.`);
      return { preflight: true, preflight_override_reason: failed.length ? reason.value.trim() : '' };
    },
  };
}
