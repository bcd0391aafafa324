// The Results page's "One view for every camera" (docs/maps.md, "One view
// for every camera"): each camera's maps resampled into the reference
// camera's grid (Results.cameras[].common_view_file), one map explorer each,
// their zoom, pan and region linked with one another (not with the
// per-camera explorers, whose grids differ), with the homography's residual.
import { formatNumber, h } from './dom.js';
import { mapExplorer } from './map_explorer.js';
import { linkedView } from './maps/linked_view.js';

// The card, or null when the session has fewer than two cameras with maps.
export function commonViewSection(results, relativeTo) {
  const cameras = (results.cameras ?? []).filter((c) => c.common_view_reference);
  if (cameras.length < 2) return null;
  const view = linkedView();
  const reference = cameras[0].common_view_reference;
  // The common view is the reference camera's grid: its scale.
  const pixelMm = (results.cameras ?? []).find((c) => c.camera === reference)?.summary?.map_pixel_mm ?? 0;
  const rows = cameras.map((camera) => {
    if (!camera.common_view_file) {
      return h('p', { class: 'message error' }, `${camera.camera}: no common view — ${camera.common_view_reason}`);
    }
    const note = camera.camera === reference
      ? `${camera.camera}: the reference (its own maps)`
      : `${camera.camera}: residual ${formatNumber(camera.common_view_residual_px, 2)} cells (the white target's outline against ${reference}'s)`;
    return h('div', { 'data-common-view': camera.camera },
      h('p', { class: 'common-view-note' }, note),
      mapExplorer(results.session_id, relativeTo(results.folder, camera.common_view_file), `${camera.camera} (common view)`, view, pixelMm));
  });
  return h('section', { class: 'card', 'aria-label': 'One view for every camera' },
    h('h3', {}, `One view for every camera (${reference}'s grid)`),
    h('p', {}, 'Every camera\'s maps resampled into one grid through the white target both cameras see: a point of the skin is at the same place in each map below; zoom, pan and the region move them together.'),
    h('div', { class: 'explorers' }, ...rows));
}
