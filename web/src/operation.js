// An operation's progress (OperationService.GetOperation, polled), shown as a
// <progress>, its state and message, with pause/resume/cancel buttons.
import * as api from './api.js';
import { h, messageArea, enumName, formatNumber } from './dom.js';

const FINAL_STATES = new Set(['OPERATION_STATE_SUCCEEDED', 'OPERATION_STATE_FAILED', 'OPERATION_STATE_CANCELLED',
  'OPERATION_STATE_INTERRUPTED']);

export function isFinal(operation) {
  return FINAL_STATES.has(operation.state);
}

export function stateName(operation) {
  return enumName(operation?.state, 'OPERATION_STATE_');
}

// Returns {element, follow(operation), close()}; onFinished(operation) once it ends.
export function operationView({ controls = false, onFinished = () => {} } = {}) {
  const bar = h('progress', { max: 1, value: 0 });
  const label = h('p', { class: 'operation-state', 'aria-live': 'polite' });
  const counters = h('p', { class: 'muted' });
  const message = messageArea();
  let current = null;
  let timer = null;
  const act = (method) => async () => {
    if (!current) return;
    message.clear();
    try {
      show(await api.call('OperationService', method, { id: current.id }));
    } catch (error) {
      message.error(error);
    }
  };
  const pause = h('button', { type: 'button', onclick: act('PauseOperation') }, 'Pause');
  const resume = h('button', { type: 'button', onclick: act('ResumeOperation') }, 'Resume');
  const cancelNow = act('CancelOperation');
  const cancel = h('button', { type: 'button', onclick: () => {
    if (current && window.confirm(`Cancel ${current.name || current.id}? Stored frames stay; the LEDs go off.`)) cancelNow();
  } }, 'Cancel');
  const buttons = controls ? h('div', { class: 'buttons' }, pause, resume, cancel) : null;
  bar.id = `progress-${Math.random().toString(36).slice(2)}`;
  const barLabel = h('label', { htmlFor: bar.id }, 'Progress');
  const element = h('div', { class: 'operation', hidden: true }, barLabel, bar, label, counters, buttons, message.element);

  function show(operation) {
    current = operation;
    element.hidden = false;
    element.dataset.state = operation.state;
    element.dataset.operationId = operation.id;
    bar.value = operation.progress ?? 0;
    const eta = operation.eta_seconds >= 0 ? `, about ${Math.round(operation.eta_seconds)} s left` : '';
    const steps = operation.step_count ? `, step ${operation.step_index + 1} of ${operation.step_count}` : '';
    label.textContent = `${operation.name || operation.id}: ${stateName(operation)} ` +
      `(${Math.round(100 * (operation.progress ?? 0))} %${steps}${eta})` +
      (operation.message ? ` — ${operation.message}` : '') + (operation.error ? ` — error: ${operation.error}` : '');
    const c = operation.counters ?? {};
    counters.textContent = c.expected && Number(c.expected) > 0
      ? `frames: ${c.stored} of ${c.expected} stored, ${c.estimated} estimated, ${c.lost} lost, ${c.estimator_skipped} skipped`
      : '';
    if (buttons) {
      const final = isFinal(operation);
      pause.disabled = final || operation.state === 'OPERATION_STATE_PAUSED';
      resume.disabled = final || operation.state !== 'OPERATION_STATE_PAUSED';
      cancel.disabled = final;
    }
    if (isFinal(operation)) {
      clearInterval(timer);
      timer = null;
      onFinished(operation);
    }
  }

  async function poll() {
    if (!current) return;
    try {
      show(await api.call('OperationService', 'GetOperation', { id: current.id }));
    } catch (error) {
      message.error(error);
    }
  }

  return {
    element,
    follow(operation) {
      clearInterval(timer);
      show(operation);
      if (!isFinal(operation)) timer = setInterval(poll, 500);
    },
    close() {
      clearInterval(timer);
    },
    formatEta: formatNumber,
  };
}
