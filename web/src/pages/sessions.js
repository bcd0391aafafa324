// Sessions: the standard plan, starting a session (subject, plan options),
// its progress and events with pause/resume/cancel, and past sessions.
import * as api from '../api.js';
import { h, field, messageArea, table, enumName, formatNumber, formatExposure, polarisationName, humanError } from '../dom.js';
import { operationView, stateName, isFinal } from '../operation.js';
import { preflightChecklist } from '../preflight.js';

function stepIllumination(step) {
  if (step.dark) return 'dark';
  if (step.mix) return `mix ${step.mix}`;
  if (step.weights) return Object.entries(step.weights).map(([k, v]) => `${k} ${formatNumber(v)}`).join(', ');
  return '–';
}

function planTable(plan) {
  return table(['#', 'Step', 'Role', 'Illumination', 'Polarisation', 'Exposure', 'Frames per camera', 'Prompt'],
    (plan.steps ?? []).map((step, i) => [i + 1, step.name, enumName(step.role, 'STEP_ROLE_'), stepIllumination(step),
      step.dark ? '–' : polarisationName(step.polarisation),
      step.exposure_from ? `from ${step.exposure_from}` : step.meter_white_share ? `metered to ${step.meter_white_share} of full scale` : formatExposure(step.exposure_us),
      step.frames_per_camera, step.prompt || '–']),
    `Plan "${plan.name}" (${enumName(plan.timing, 'TIMING_')} timing)`);
}

// The past sessions, told apart by subject, study and operator; a search
// over those and the id, a state filter, and Delete (after a confirmation)
// for a finished session.
function pastSessions() {
  const body = h('div', {});
  const message = messageArea();
  const search = h('input', { type: 'search', name: 'session_search', placeholder: 'subject, study, operator or id' });
  const stateFilter = h('select', { name: 'session_state' }, h('option', { value: '' }, 'any state'),
    ['succeeded', 'running', 'paused', 'failed', 'cancelled', 'interrupted'].map((state) => h('option', { value: state }, state)));
  let sessions = [];
  const remove = async (session) => {
    if (!window.confirm(`Delete session ${session.id} (${session.subject || 'no subject'})? Its frames, maps and files are removed for good.`)) return;
    try {
      const deleted = await api.call('SessionService', 'DeleteSession', { id: session.id });
      message.info(`session ${deleted.id} deleted: ${deleted.files_removed ?? 0} files`);
      await refresh();
    } catch (error) {
      message.error(error);
    }
  };
  const render = () => {
    const words = search.value.trim().toLowerCase();
    const shown = sessions.filter((session) =>
      (!stateFilter.value || stateName(session.operation) === stateFilter.value) &&
      (!words || [session.id, session.subject, session.study, session.operator_name]
        .some((text) => (text ?? '').toLowerCase().includes(words))));
    body.replaceChildren(shown.length ? table(['Session', 'Subject', 'Study', 'Operator', 'State', 'Frames', 'Created', 'Results', ''],
      shown.map((session) => {
        const operation = session.operation ?? {};
        const step = !isFinal(operation) && operation.step_count
          ? ` (step ${Math.max(0, operation.step_index ?? -1) + 1} of ${operation.step_count})` : '';
        return [session.id, session.subject || '–', session.study || '–', session.operator_name || '–', `${stateName(operation)}${step}`,
          String(operation.counters?.stored ?? 0), operation.created ?? '–',
          h('a', { href: `#results/${encodeURIComponent(session.id)}` }, `Results of ${session.id}`),
          isFinal(session.operation) ? h('button', { type: 'button', class: 'danger', 'data-delete': session.id,
            onclick: () => remove(session) }, 'Delete') : '–'];
      }), `Past sessions (${shown.length} of ${sessions.length})`)
      : h('p', {}, sessions.length ? 'No session matches.' : 'No sessions yet.'));
  };
  const refresh = async () => {
    try {
      ({ sessions = [] } = await api.call('SessionService', 'ListSessions', { limit: 500 }));
      render();
    } catch (error) {
      message.error(error);
    }
  };
  search.addEventListener('input', render);
  stateFilter.addEventListener('change', render);
  refresh();
  return { section: h('section', { class: 'card', 'aria-labelledby': 'past-heading' },
    h('h3', { id: 'past-heading' }, 'Past sessions'),
    h('div', { class: 'filters' }, field('Search', search), field('State', stateFilter)), body,
    h('button', { type: 'button', onclick: refresh }, 'Refresh the list'), message.element), refresh };
}

// The form's values survive leaving the page (sessionStorage, this tab only).
const FORM_KEY = 'chromo.sessionForm';
function keepForm(controls) {
  let saved = {};
  try { saved = JSON.parse(sessionStorage.getItem(FORM_KEY) ?? '{}') ?? {}; } catch { saved = {}; }
  for (const control of controls) {
    if (!(control.name in saved)) continue;
    if (control.type === 'checkbox') control.checked = Boolean(saved[control.name]);
    else control.value = String(saved[control.name]);
  }
  const save = () => sessionStorage.setItem(FORM_KEY, JSON.stringify(Object.fromEntries(
    controls.map((control) => [control.name, control.type === 'checkbox' ? control.checked : control.value]))));
  for (const control of controls) {
    control.addEventListener('input', save);
    control.addEventListener('change', save);
  }
}

export function mountSessions(container) {
  const subject = h('input', { type: 'text', maxLength: 4096, value: '', name: 'subject' });
  const operatorName = h('input', { type: 'text', maxLength: 4096, value: '', name: 'operator_name', autocomplete: 'name' });
  const study = h('input', { type: 'text', maxLength: 4096, value: '', name: 'study' });
  const prompts = h('input', { type: 'checkbox', name: 'operator_prompts' });
  const fixed = h('input', { type: 'checkbox', name: 'fixed_exposure' });
  const exposure = h('input', { type: 'number', min: 0, max: 10000000, step: 'any', value: 10000, name: 'exposure_us' });
  const frames = h('input', { type: 'number', min: 0, max: 1000, step: 1, value: 0, name: 'frames_per_camera' });
  const referenceFrames = h('input', { type: 'number', min: 0, max: 1000, step: 1, value: 0, name: 'reference_frames' });
  const polarised = h('select', { name: 'polarised' },
    h('option', { value: 'POLARISED_PLAN_CONFIGURED' }, 'as configured (cross-polarised where the sphere has banks)'),
    h('option', { value: 'POLARISED_PLAN_ON' }, 'cross-polarised, with a parallel D65\' capture'),
    h('option', { value: 'POLARISED_PLAN_OFF' }, 'unpolarised'));
  const timing = h('select', { name: 'timing' },
    h('option', { value: 'TIMING_SOFTWARE' }, 'software'), h('option', { value: 'TIMING_HARDWARE' }, 'hardware'));
  const plan = h('div', { class: 'plan' });
  const message = messageArea();
  const events = h('ol', { class: 'events', 'aria-label': 'Events of the session' });
  let followedId = null;
  const past = pastSessions();
  const preflight = preflightChecklist();
  const progress = operationView({ controls: true, onFinished: () => past.refresh() });

  // A plan this sphere cannot run (a polarised one without polariser banks,
  // hardware timing beyond the controller's sequence, …) is refused as it is
  // chosen: chromod's reason (GetStandardPlan's start_refusal, StartSession's
  // own words) under the plan options, and Start disabled until it changes.
  const startButton = h('button', { type: 'submit' }, 'Start session');
  const refusal = h('p', { class: 'message error plan-refusal', role: 'alert', hidden: true });
  const showRefusal = (text) => {
    refusal.hidden = !text;
    refusal.textContent = text ? `This plan cannot run on this sphere: ${text}` : '';
    startButton.disabled = Boolean(text);
    startButton.title = text ? 'Change the plan options: chromod would refuse this plan' : '';
  };
  const options = () => ({ timing: timing.value, exposure_us: Number(exposure.value), frames_per_camera: Number(frames.value),
    reference_frames: Number(referenceFrames.value), polarised: polarised.value,
    operator_prompts: prompts.checked, fixed_exposure: fixed.checked });
  let planRequest = 0;  // only the newest request's plan is shown
  const showPlan = async () => {
    const request = ++planRequest;
    try {
      const shown = await api.call('SessionService', 'GetStandardPlan', options());
      if (request !== planRequest) return;
      plan.replaceChildren(planTable(shown));
      showRefusal(shown.start_refusal);
    } catch (error) {
      if (request !== planRequest) return;
      plan.replaceChildren(h('p', { class: 'message error' }, humanError(error)));
      showRefusal(humanError(error));
    }
  };
  keepForm([subject, operatorName, study, prompts, fixed, exposure, frames, referenceFrames, polarised, timing]);
  for (const control of [prompts, fixed, exposure, frames, referenceFrames, polarised, timing]) control.addEventListener('change', showPlan);
  showPlan();

  const form = h('form', { class: 'start-session' },
    field('Subject', subject), field('Operator', operatorName), field('Study', study),
    h('fieldset', {}, h('legend', {}, 'Plan: the standard session'),
      field('Timing', timing), field('Exposure (µs)', exposure), field('Frames per camera (0: configured)', frames),
      field('Frames per dark and white reference (0: configured)', referenceFrames), field('Polarisation', polarised),
      h('label', { class: 'check' }, prompts, ' Pause for "place white" and "place subject"'),
      h('label', { class: 'check' }, fixed, ' One fixed exposure (no metering)'), refusal),
    preflight.element, startButton);
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    if (startButton.disabled) return;  // Enter in a field submits too
    message.clear();
    events.replaceChildren();
    try {
      const operation = await api.call('SessionService', 'StartSession', { standard: true, subject: subject.value,
        operator_name: operatorName.value, study: study.value, ...options(), ...preflight.request() });
      followedId = operation.id;
      progress.follow(operation);
      message.info(`session ${operation.id} started`);
      past.refresh();
    } catch (error) {
      message.error(error);
    }
  });

  const closeEvents = api.openStream('/api/stream/events', (event) => {
    const text = event.log ? event.log
      : event.operation ? `${event.operation.id}: ${stateName(event.operation)} ${Math.round(100 * (event.operation.progress ?? 0))} % ${event.operation.message ?? ''}`
        : null;
    if (!text) return;
    if (event.operation && followedId && event.operation.id !== followedId) return;
    events.prepend(h('li', {}, `${event.time ?? ''} ${text}`));
    while (events.childElementCount > 30) events.lastElementChild.remove();
    if (event.operation && event.operation.id === followedId && isFinal(event.operation)) past.refresh();
  });

  // A running session (started elsewhere or before a reload) is followed too.
  api.call('OperationService', 'ListOperations', { kind: 'OPERATION_KIND_SESSION', limit: 20 }).then(({ operations = [] }) => {
    const running = operations.find((operation) => !isFinal(operation));
    if (running && !followedId) {
      followedId = running.id;
      progress.follow(running);
    }
  }, () => {});

  container.append(h('h2', {}, 'Sessions'),
    h('div', { class: 'columns' },
      h('section', { class: 'card', 'aria-labelledby': 'start-heading' }, h('h3', { id: 'start-heading' }, 'Start a session'),
        form, message.element, progress.element, h('h4', {}, 'Events'), events),
      h('section', { class: 'card', 'aria-labelledby': 'plan-heading' }, h('h3', { id: 'plan-heading' }, 'Plan'), plan)),
    past.section);
  return () => {
    progress.close();
    closeEvents();
  };
}
