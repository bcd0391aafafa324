// Results: a session's estimation results (ResultsService.GetResults): the
// headline figures, each camera's maps (map_explorer.js: any channel of
// maps.exr with its contrast, the value under the cursor and region
// statistics, zoom and pan linked across maps and cameras; the previews
// chromod wrote next to maps.exr, each opening full size) and links to the files; relighting (MapsService.Relight) under
// the offered illuminants with the photograph | reconstruction | ΔE94 panel
// and its figures; before and after against another session of the subject
// (maps/session_comparison.js); the session's frames with each one's step, exposure and
// polarisation (GetSession with frames).
import * as api from '../api.js';
import { h, field, messageArea, table, enumName, formatNumber, formatExposure, polarisationName } from '../dom.js';
import { mapExplorer } from '../map_explorer.js';
import { provenanceCard } from '../provenance.js';
import { linkedView } from '../maps/linked_view.js';
import { commonViewSection } from '../common_view.js';
import { comparisonSection } from '../maps/session_comparison.js';

const ILLUMINANTS = ['D65', 'D50', 'A', '4000K', 'W57', 'W40', 'W27', 'R', 'G', 'B'];
const MAP_PREVIEWS = [['cm', 'Cm (melanin)'], ['ch', 'Ch (hemoglobin)'], ['bm', 'βm (melanin blend)'],
  ['che', 'Che (epidermal hemoglobin)'], ['sigma_cm', 'σ of Cm'], ['sigma_ch', 'σ of Ch'], ['residual', 'Residual'],
  ['order', 'Model order'], ['flags', 'Flags']];

function relativeTo(folder, path) {
  const prefix = folder.endsWith('/') ? folder : `${folder}/`;
  return path.startsWith(prefix) ? path.slice(prefix.length) : path;
}

function deltaETable(statistics, caption) {
  return table(['Illuminant', 'Mean', 'Median', 'p95', 'Max', 'Pixels'],
    Object.entries(statistics ?? {}).map(([name, s]) => [name, formatNumber(s.mean, 3), formatNumber(s.median, 3),
      formatNumber(s.p95, 3), formatNumber(s.max, 3), s.pixels]), caption);
}

// How highlights were found (docs/polarisation.md): optically from a
// parallel − cross pair, with its diffuse | surface | combined panel, or by the
// estimator's heuristics on an unpolarised session.
function highlightSection(results, camera, folder) {
  const summary = camera.summary ?? {};
  if (!summary.highlight_detection) return null;
  const optical = summary.highlight_detection === 'optical';
  const text = optical
    ? `Highlights: optical (parallel − cross): ${summary.highlight_pixels ?? 0} pixels flagged, information only — ` +
      'the diffuse maps there come from the cross-polarised captures; maps.exr holds the surface and highlight channels.'
    : `Highlights: heuristic (no parallel-polarised capture): ${summary.highlight_pixels ?? 0} pixels flagged specular.`;
  return h('div', { class: 'highlights', 'data-detection': summary.highlight_detection },
    h('p', {}, text),
    optical ? h('figure', { class: 'panel' },
      h('img', { src: api.fileUrl(results.session_id, `${folder}polarisation.png`), alt: `${camera.camera}: diffuse | surface | combined`, loading: 'lazy' }),
      h('figcaption', {}, 'Diffuse (cross-polarised) | surface (parallel − cross) | combined')) : null);
}

const FRAMES_SHOWN = 500;

// The polarisation of the LED types a frame's light was made of (drive > 0,
// W57 W40 W27 R G B as FrameRecord.polarisation lists them); '–' for dark.
const LED_TYPES = ['w57', 'w40', 'w27', 'red', 'green', 'blue'];
function frameLights(frame) {
  const states = new Set((frame.polarisation ?? []).filter((_, i) => Number(frame.drive?.[LED_TYPES[i]] ?? 0) > 0)
    .map(polarisationName));
  return states.size ? [...states].join(' + ') : '–';
}

// The session's frames as its journal has them (GetSession include_frames).
function framesSection(sessionId) {
  const body = h('div', {}, h('p', {}, 'loading the frames…'));
  const message = messageArea();
  api.call('SessionService', 'GetSession', { id: sessionId, include_frames: true }).then((detail) => {
    const frames = detail.frames ?? [];
    const shown = frames.slice(0, FRAMES_SHOWN);
    body.replaceChildren(
      h('p', {}, frames.length > shown.length ? `${frames.length} frames; the first ${shown.length} are listed.` : `${frames.length} frames.`),
      table(['#', 'Step', 'Camera', 'Sequence', 'Exposure', 'Polarisation', 'Status'],
        shown.map((frame) => [frame.index ?? 0, frame.step, frame.camera, frame.sequence ?? 0, formatExposure(frame.exposure_us),
          frameLights(frame), frame.status]), 'Frames of the session'));
    body.dataset.frames = String(frames.length);
  }, (error) => { body.replaceChildren(); message.error(error); });
  return h('section', { class: 'card', 'aria-labelledby': 'frames-heading' },
    h('h3', { id: 'frames-heading' }, 'Frames'), body, message.element);
}

// The previews chromod wrote; each opens full size.
function previewFigures(results, camera, folder) {
  return h('div', { class: 'maps' }, MAP_PREVIEWS.map(([key, title]) => {
    const url = api.fileUrl(results.session_id, `${folder}${key}.png`);
    return h('figure', { class: 'map' },
      h('a', { href: url, target: '_blank', rel: 'noopener', title: `${title}: open full size` },
        h('img', { src: url, alt: `${camera.camera}: ${title} map`, loading: 'lazy' })),
      h('figcaption', {}, title));
  }));
}

// A camera's map explorers (zoom, pan and region linked with every other
// explorer of the page); "Add a map" puts another channel beside.
function explorers(results, camera, view) {
  const mapsFile = relativeTo(results.folder, camera.maps_file);
  const pixelMm = camera.summary?.map_pixel_mm ?? 0;
  const row = h('div', { class: 'explorers' }, mapExplorer(results.session_id, mapsFile, camera.camera, view, pixelMm));
  const add = h('button', { type: 'button' }, 'Add a map beside');
  add.addEventListener('click', () => row.append(mapExplorer(results.session_id, mapsFile, camera.camera, view, pixelMm)));
  return h('div', {}, row, add);
}

function cameraResults(results, camera, view) {
  const folder = relativeTo(results.folder, camera.maps_file).replace(/[^/]*$/, '');
  const summary = camera.summary ?? {};
  const maps = previewFigures(results, camera, folder);
  return h('section', { class: 'card', 'aria-label': `Results of camera ${camera.camera}`, 'data-camera': camera.camera },
    h('h3', {}, `Camera ${camera.camera}: ${enumName(camera.state, 'RESULTS_STATE_')}`),
    camera.reason ? h('p', { class: 'message error' }, camera.reason) : null,
    h('p', {}, `estimator ${summary.method}, model ${summary.model}: ${summary.pixels} pixels in ${formatNumber(summary.estimate_seconds)} s ` +
      `(${formatNumber(summary.pixels_per_second, 4)} pixels/s); sensitivity ${camera.camera_sensitivity}`),
    deltaETable(summary.relit_delta_e94, `${camera.camera}: relit ΔE94 against the photographs`),
    table(['Flag', 'Pixels'], Object.entries(summary.flag_counts ?? {}).map(([flag, count]) => [flag, count]), `${camera.camera}: flags`),
    highlightSection(results, camera, folder),
    explorers(results, camera, view),
    maps,
    h('ul', { class: 'files' },
      [camera.maps_file, camera.report_file].map((file) => {
        const relative = relativeTo(results.folder, file);
        return h('li', {}, h('a', { href: api.fileUrl(results.session_id, relative), download: '' }, relative));
      })));
}

// The photographs a relight can compare against (MapsService.ListPhotographs:
// the session folder's RGB OpenEXR files), picked rather than typed: those of
// the maps' size can be chosen, the others are listed disabled with their size.
function photographPicker(results, mapsFile) {
  const select = h('select', { name: 'photograph' }, h('option', { value: '' }, 'none'));
  const refresh = async () => {
    const chosen = select.value;
    const reply = await api.call('MapsService', 'ListPhotographs', { session_id: results.session_id, maps_file: mapsFile() });
    const photographs = reply.photographs ?? [];
    select.replaceChildren(h('option', { value: '' }, photographs.some((p) => p.same_size) ? 'none' : 'none (no RGB photograph of the maps\' size)'),
      ...photographs.map((p) => h('option', { value: p.file, disabled: !p.same_size, selected: p.file === chosen },
        p.same_size ? p.file : `${p.file} (${p.width}×${p.height}, the maps are ${reply.maps_width}×${reply.maps_height})`)));
    select.dataset.photographs = String(photographs.filter((p) => p.same_size).length);
  };
  return { select, refresh };
}

function relightSection(results) {
  const cameras = results.cameras?.length ? results.cameras : [{ camera: '', maps_file: results.maps_file }];
  const camera = h('select', {}, cameras.map((c, i) => h('option', { value: String(i) }, c.camera || 'the camera')));
  const illuminant = h('select', {}, ILLUMINANTS.map((name) => h('option', { value: name }, name)));
  const mapsFile = () => relativeTo(results.folder, cameras[Number(camera.value)].maps_file);
  // An RGB albedo EXR in the session folder (e.g. from a colour camera's
  // export, or an earlier relight's relit.exr); the session's own derived albedo is raw (one channel Y).
  const photograph = photographPicker(results, mapsFile);
  const message = messageArea('relight-message');
  const output = h('div', { class: 'relight-output', 'aria-live': 'polite' });
  const listed = () => photograph.refresh().catch((error) => message.error(error));
  camera.addEventListener('change', listed);
  listed();
  const form = h('form', { class: 'inline' },
    field('Camera', camera), field('Illuminant', illuminant), field('Photograph to compare (in the session folder)', photograph.select),
    h('button', { type: 'submit' }, 'Relight'));
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    message.info('relighting…');
    output.replaceChildren();
    delete output.dataset.relit;
    try {
      const reply = await api.call('MapsService', 'Relight', {
        session_id: results.session_id, maps_file: mapsFile(),
        illuminant: illuminant.value, photograph_file: photograph.select.value });
      message.info(`relit ${reply.relit_pixels} of ${reply.width}×${reply.height} pixels under ${reply.illuminant}` +
        (reply.compared ? ` against ${photograph.select.value}` : ' (no photograph chosen: no ΔE94)'));
      const images = reply.files.filter((file) => file.endsWith('.png'));
      if (reply.compared) output.append(deltaETable({ [reply.illuminant]: reply.photo_delta_e94 }, 'ΔE94 of the reconstruction against the photograph'));
      output.append(
        h('div', { class: 'panels' }, images.map((file) => h('figure', {},
          h('img', { src: api.fileUrl(results.session_id, file), alt: `relit under ${reply.illuminant}: ${file.split('/').pop()}` }),
          h('figcaption', {}, file.split('/').pop())))),
        h('ul', { class: 'files' }, reply.files.map((file) => h('li', {}, h('a', { href: api.fileUrl(results.session_id, file), download: '' }, file)))));
      output.dataset.relit = JSON.stringify({ relit_pixels: reply.relit_pixels, width: reply.width, height: reply.height,
        compared: reply.compared, photo_delta_e94: reply.compared ? reply.photo_delta_e94 : null });
      await listed();  // the relight's own relit.exr is a photograph of the maps' size now
    } catch (error) {
      message.error(error);
    }
  });
  return h('section', { class: 'card', 'aria-labelledby': 'relight-heading' },
    h('h3', { id: 'relight-heading' }, 'Relight'), form, message.element, output);
}

export function mountResults(container, sessionId) {
  const choose = h('select', { name: 'session' }, h('option', { value: '' }, 'choose a session'));
  const body = h('div', {});
  const message = messageArea();
  const show = async (id) => {
    body.replaceChildren();
    message.clear();
    if (!id) return;
    try {
      const results = await api.call('ResultsService', 'GetResults', { session_id: id });
      body.dataset.sessionId = id;
      body.append(h('p', { class: 'results-state' }, `Session ${id}: results ${enumName(results.state, 'RESULTS_STATE_')}`,
        results.reason ? ` — ${results.reason}` : ''), provenanceCard(results.provenance));
      if (results.state !== 'RESULTS_STATE_AVAILABLE') {
        body.append(framesSection(id));
        return;
      }
      const view = linkedView();
      body.append(relightSection(results), ...(results.cameras ?? []).map((camera) => cameraResults(results, camera, view)));
      const common = commonViewSection(results, relativeTo);
      if (common) body.append(common);
      body.append(comparisonSection(results), framesSection(id));
    } catch (error) {
      message.error(error);
    }
  };
  choose.addEventListener('change', () => { location.hash = `#results/${encodeURIComponent(choose.value)}`; });
  api.call('SessionService', 'ListSessions', { limit: 100 }).then(({ sessions = [] }) => {
    for (const session of sessions)
      choose.append(h('option', { value: session.id, selected: session.id === sessionId }, `${session.id} (${enumName(session.operation?.state, 'OPERATION_STATE_')})`));
  }, (error) => message.error(error));
  container.append(h('h2', {}, 'Results'), field('Session', choose), message.element, body);
  show(sessionId);
}
