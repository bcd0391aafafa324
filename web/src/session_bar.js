// The running session or calibration on every page (issue 41): a full-width
// bar under the header with its name, state, step and progress. When a
// session waits for the operator (PAUSED, with the step's prompt such as
// "place the white reference target"), the prompt fills the bar in large
// type with Continue (the Space key) and Cancel (the Escape key, after a
// confirmation; the daemon audits every cancel).
import * as api from './api.js';
import { h, messageArea } from './dom.js';
import { stateName, isFinal } from './operation.js';

const POLL_MS = 1000;

// Space and Escape belong to the control that has the focus when it takes keys itself.
function takesKeys(element) {
  return element instanceof HTMLElement &&
    (element.isContentEditable || ['INPUT', 'TEXTAREA', 'SELECT', 'BUTTON', 'A'].includes(element.tagName) ||
     element.tabIndex >= 0 && element.tagName === 'CANVAS');
}

// element: the bar's container (index.html's #session-bar). Returns stop().
export function startSessionBar(element) {
  let current = null;
  let timer = null;
  let stopped = false;
  const text = h('p', { class: 'session-bar-text' });
  const prompt = h('p', { class: 'session-bar-prompt' });
  const progress = h('progress', { max: 1, value: 0, 'aria-label': 'Progress of the running operation' });
  const message = messageArea();
  const act = async (method) => {
    if (!current) return;
    try {
      show(await api.call('OperationService', method, { id: current.id }));
      message.clear();
    } catch (error) {
      message.error(error);
    }
  };
  const confirmCancel = () => {
    if (!current || isFinal(current)) return;
    const what = current.kind === 'OPERATION_KIND_CALIBRATION' ? 'calibration' : 'session';
    if (window.confirm(`Cancel the ${what} ${current.name || current.id}? Stored frames stay; the LEDs go off.`)) act('CancelOperation');
  };
  const resume = h('button', { type: 'button', onclick: () => act('ResumeOperation') }, 'Continue (Space)');
  const cancel = h('button', { type: 'button', class: 'danger', onclick: confirmCancel }, 'Cancel (Esc)');
  element.replaceChildren(h('div', { class: 'session-bar-body' }, prompt, text, progress,
    h('div', { class: 'buttons' }, resume, cancel), message.element));

  function show(operation) {
    current = operation && !isFinal(operation) ? operation : null;
    element.hidden = !current;
    document.body.classList.toggle('operation-running', Boolean(current));
    if (!current) return;
    const paused = current.state === 'OPERATION_STATE_PAUSED';
    element.dataset.state = current.state;
    element.dataset.operationId = current.id;
    element.classList.toggle('waiting', paused);
    prompt.hidden = !paused;
    prompt.textContent = paused ? (current.message || 'Paused') : '';
    const step = current.step_count ? `, step ${current.step_index + 1} of ${current.step_count}` : '';
    const kind = current.kind === 'OPERATION_KIND_CALIBRATION' ? 'Calibration' : 'Session';
    text.textContent = `${kind} ${current.name || current.id}: ${stateName(current)}${step}, ` +
      `${Math.round(100 * (current.progress ?? 0))} %${!paused && current.message ? ` — ${current.message}` : ''}`;
    progress.value = current.progress ?? 0;
    resume.hidden = !paused;
  }

  async function poll() {
    try {
      const { operations = [] } = await api.call('OperationService', 'ListOperations', { limit: 5 });
      show(operations.find((operation) => !isFinal(operation)) ?? null);
    } catch {
      // The connection banner says when the daemon is away.
    }
    if (!stopped) timer = setTimeout(poll, POLL_MS);
  }

  const onKey = (event) => {
    if (!current || event.defaultPrevented || event.altKey || event.ctrlKey || event.metaKey) return;
    if (event.key === ' ' && current.state === 'OPERATION_STATE_PAUSED' && !takesKeys(event.target)) {
      event.preventDefault();
      act('ResumeOperation');
    } else if (event.key === 'Escape') {
      event.preventDefault();
      confirmCancel();
    }
  };
  document.addEventListener('keydown', onKey);
  poll();
  return () => {
    stopped = true;
    clearTimeout(timer);
    document.removeEventListener('keydown', onKey);
    element.hidden = true;
  };
}
