// The zoom, pan and region every map explorer of a page shares, so maps of
// one camera and of several cameras move together. Coordinates are fractions
// of the map's width and height (0-1), so maps of different sizes line up.

export function linkedView() {
  const listeners = new Set();
  const state = { zoom: 1, centreX: 0.5, centreY: 0.5, region: null };  // region: {x0, y0, x1, y1} fractions
  const clampCentre = () => {
    const half = 0.5 / state.zoom;
    state.centreX = Math.min(Math.max(state.centreX, half), 1 - half);
    state.centreY = Math.min(Math.max(state.centreY, half), 1 - half);
  };
  const changed = (what) => { for (const listener of listeners) listener(what); };
  return {
    state,
    subscribe(listener) { listeners.add(listener); return () => listeners.delete(listener); },
    // The visible part of the map: its top-left corner and size, as fractions.
    window() {
      const size = 1 / state.zoom;
      return { x: state.centreX - size / 2, y: state.centreY - size / 2, size };
    },
    // Zoom by `factor` (1-64×) keeping the point (fx, fy) where it is on screen.
    zoomBy(factor, fx = state.centreX, fy = state.centreY) {
      const zoom = Math.min(Math.max(state.zoom * factor, 1), 64);
      const keep = state.zoom / zoom;
      state.centreX = fx + (state.centreX - fx) * keep;
      state.centreY = fy + (state.centreY - fy) * keep;
      state.zoom = zoom;
      clampCentre();
      changed('view');
    },
    panBy(dx, dy) {
      state.centreX += dx;
      state.centreY += dy;
      clampCentre();
      changed('view');
    },
    reset() {
      Object.assign(state, { zoom: 1, centreX: 0.5, centreY: 0.5 });
      changed('view');
    },
    setRegion(region) {
      state.region = region;
      changed('region');
    },
  };
}
