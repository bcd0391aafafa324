// Sessions: the standard plan, starting a session (subject, plan options),
// its progress and events with pause/resume/cancel, and past sessions.
import * as api from '../api.js';
import { h, field, messageArea, table, enumName, formatNumber, polarisationName } from '../dom.js';
import { operationView, stateName, isFinal } from '../operation.js';

function stepIllumination(step) {
  if (step.dark) return 'dark';
  if (step.mix) return `mix ${step.mix}`;
  if (step.weights) return Object.entries(step.weights).map(([k, v]) => `${k} ${formatNumber(v)}`).join(', ');
  return '–';
}

function planTable(plan) {
  return table(['#', 'Step', 'Role', 'Illumination', 'Polarisation', 'Exposure (µs)', 'Frames per camera', 'Prompt'],
    (plan.steps ?? []).map((step, i) => [i + 1, step.name, enumName(step.role, 'STEP_ROLE_'), stepIllumination(step),
      step.dark ? '–' : polarisationName(step.polarisation),
      step.exposure_from ? `from ${step.exposure_from}` : step.meter_white_share ? `metered to ${step.meter_white_share} of full scale` : formatNumber(step.exposure_us),
      step.frames_per_camera, step.prompt || '–']),
    `Plan "${plan.name}" (${enumName(plan.timing, 'TIMING_')} timing)`);
}

function pastSessions(onOpen) {
  const body = h('div', {});
  const message = messageArea();
  const refresh = async () => {
    try {
      const { sessions = [] } = await api.call('SessionService', 'ListSessions', { limit: 50 });
      body.replaceChildren(sessions.length ? table(['Session', 'Name', 'State', 'Progress', 'Created', 'Results'],
        sessions.map((session) => [session.id, session.name, stateName(session.operation),
          `${Math.round(100 * (session.operation?.progress ?? 0))} %`, session.operation?.created ?? '–',
          h('a', { href: `#results/${encodeURIComponent(session.id)}` }, `Results of ${session.id}`)]), 'Past sessions')
        : h('p', {}, 'No sessions yet.'));
    } catch (error) {
      message.error(error);
    }
  };
  refresh();
  return { section: h('section', { class: 'card', 'aria-labelledby': 'past-heading' },
    h('h3', { id: 'past-heading' }, 'Past sessions'), body,
    h('button', { type: 'button', onclick: refresh }, 'Refresh the list'), message.element), refresh, onOpen };
}

export function mountSessions(container) {
  const subject = h('input', { type: 'text', maxLength: 4096, value: '', name: 'subject' });
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
  const progress = operationView({ controls: true, onFinished: () => past.refresh() });

  const options = () => ({ timing: timing.value, exposure_us: Number(exposure.value), frames_per_camera: Number(frames.value),
    reference_frames: Number(referenceFrames.value), polarised: polarised.value,
    operator_prompts: prompts.checked, fixed_exposure: fixed.checked });
  const showPlan = async () => {
    try {
      plan.replaceChildren(planTable(await api.call('SessionService', 'GetStandardPlan', options())));
    } catch (error) {
      plan.replaceChildren(h('p', { class: 'message error' }, `${error.message} (${error.code})`));
    }
  };
  for (const control of [prompts, fixed, exposure, frames, referenceFrames, polarised, timing]) control.addEventListener('change', showPlan);
  showPlan();

  const form = h('form', { class: 'start-session' },
    field('Subject', subject),
    h('fieldset', {}, h('legend', {}, 'Plan: the standard session'),
      field('Timing', timing), field('Exposure (µs)', exposure), field('Frames per camera (0: configured)', frames),
      field('Frames per dark and white reference (0: configured)', referenceFrames), field('Polarisation', polarised),
      h('label', { class: 'check' }, prompts, ' Pause for "place white" and "place subject"'),
      h('label', { class: 'check' }, fixed, ' One fixed exposure (no metering)')),
    h('button', { type: 'submit' }, 'Start session'));
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    message.clear();
    events.replaceChildren();
    try {
      const operation = await api.call('SessionService', 'StartSession', { standard: true, subject: subject.value, ...options() });
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
