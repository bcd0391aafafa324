// The scale bar of a map whose pixel size on the subject is known
// (ResultsSummary.map_pixel_mm; docs/maps.md "Scale bar"): the longest
// 1-2-5 × 10^k mm length within a quarter of the visible width, as the
// previews choose theirs (maps/map_previews.hpp scale_bar_for).

// {mm, mapPixels} for `widthPx` visible map pixels of `pixelMm` each; null when unknown.
export function scaleBarFor(widthPx, pixelMm) {
  if (!(pixelMm > 0) || !(widthPx >= 4)) return null;
  const longest = 0.25 * widthPx * pixelMm;
  let mm = 10 ** Math.floor(Math.log10(longest));
  for (const step of [5, 2]) if (mm * step <= longest * (1 + 1e-9)) { mm *= step; break; }
  mm = Number(mm.toPrecision(12));
  return { mm, mapPixels: mm / pixelMm };
}

// Draws the bar in the canvas's bottom-left corner for a view showing
// `visibleMapPixels` map pixels across the canvas; returns {mm, canvasPx} or null.
export function drawScaleBar(context, visibleMapPixels, pixelMm) {
  const bar = scaleBarFor(visibleMapPixels, pixelMm);
  if (!bar) return null;
  const { width, height } = context.canvas;
  const canvasPx = bar.mapPixels * width / visibleMapPixels;
  const x = 16, y = height - 24;
  context.fillStyle = '#000';
  context.fillRect(x - 2, y - 2, canvasPx + 4, 12);
  context.fillStyle = '#fff';
  context.fillRect(x, y, canvasPx, 8);
  context.font = 'bold 24px sans-serif';
  context.lineWidth = 4;
  context.strokeStyle = '#000';
  context.strokeText(`${bar.mm} mm`, x, y - 8);
  context.fillText(`${bar.mm} mm`, x, y - 8);
  return { mm: bar.mm, canvasPx };
}
