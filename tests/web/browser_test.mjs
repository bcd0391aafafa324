// The web view in a real browser (issue 22; docs/web.md): Debian's chromium
// driven by playwright-core (web/package.json) against a real chromod on the
// built-in virtual lab (one 640x480 camera) on loopback.
//
//   node tests/web/browser_test.mjs CHROMOD WEB_DIR SCREENSHOT_DIR
//
// Exit 0 pass, 1 fail, 77 skipped (no chromium, or web/node_modules missing).
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, mkdirSync, writeFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import assert from 'node:assert/strict';
import { browserOrSkip, Chromod, waitUntil, callApi, runMain, wordsBrokenAcrossLines } from './harness.mjs';
import { formatNumber } from '../../web/src/dom.js';
import { diverging, viridis, percentileOfSorted } from '../../web/src/maps/colour_scale.js';

const [chromod, webDir, screenshotDir] = process.argv.slice(2);
mkdirSync(screenshotDir, { recursive: true });
const { playwright, chromium } = browserOrSkip();
assert.ok(chromod && existsSync(chromod), `chromod: ${chromod} does not exist`);
assert.ok(existsSync(path.join(webDir, 'app.js')), `web dir ${webDir}: no app.js (build the target web)`);

const TOKEN = 'browser-test-token-0123456789abcdef';
const home = mkdtempSync(path.join(tmpdir(), 'chromo-web-test-'));
const runDir = path.join(home, 'run');
mkdirSync(runDir);
writeFileSync(path.join(home, 'chromod.json'), JSON.stringify({ token: TOKEN, web_dir: webDir }));
const figures = {};
const time = (name, started) => { figures[name] = Math.round(performance.now() - started); };

// chromod (tests/web/harness.mjs); its configuration file is rewritten for the polarised lab.
const daemon = new Chromod(chromod, home, path.join(home, 'chromod.json'), runDir);
let browser = null;
const startDaemon = (port = 0) => daemon.start(port);
const stopDaemon = () => daemon.stop();

// The API from the test itself (node's fetch), with its own log-in cookie.
let origin;
let cookie = '';
const api = (service, method, body, headers = {}) => callApi(origin, cookie, service, method, body, headers);

async function meanBrightness(page) {
  return page.evaluate(() => {
    const canvas = document.querySelector('canvas.picture');
    const data = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    let sum = 0;
    for (let i = 0; i < data.length; i += 4) sum += data[i] + data[i + 1] + data[i + 2];
    return sum / (3 * data.length / 4);
  });
}
async function waitForNewFrames(page, count) {
  const before = Number(await page.locator('canvas.picture').getAttribute('data-frames') ?? 0);
  await waitUntil(page, (target) => Number(document.querySelector('canvas.picture')?.dataset.frames ?? 0) >= target,
    before + count, 20000, `${count} new preview frames`);
}

// Tab through the page: every visible control of nav and main must take the
// focus, and nothing may scroll sideways at 1280x800.
async function checkKeyboardAndWidth(page, name) {
  const width = await page.evaluate(() => ({ scroll: document.documentElement.scrollWidth, client: document.documentElement.clientWidth }));
  assert.ok(width.scroll <= width.client, `${name}: horizontal scrolling at 1280x800 (${width.scroll} > ${width.client})`);
  const controls = await page.evaluate(() => {
    const all = [...document.querySelectorAll('nav a, nav button, main a[href], main button, main input, main select, main textarea')];
    return all.filter((e) => !e.disabled && e.getClientRects().length > 0).map((e, i) => { e.dataset.tabProbe = String(i); return i; }).length;
  });
  const reached = new Set();
  await page.evaluate(() => document.activeElement?.blur());
  for (let presses = 0; presses < controls * 2 + 20 && reached.size < controls; ++presses) {
    await page.keyboard.press('Tab');
    const probe = await page.evaluate(() => document.activeElement?.dataset?.tabProbe ?? null);
    if (probe !== null) reached.add(probe);
  }
  assert.equal(reached.size, controls, `${name}: Tab reached ${reached.size} of ${controls} controls`);
  const broken = await wordsBrokenAcrossLines(page);
  assert.deepEqual(broken, [], `${name}: words broken across lines at 1280x800`);
  console.log(`${name}: Tab reaches all ${controls} controls; page width ${width.scroll} px; no word broken across lines`);
}

// The map explorer (issue 42): contrast presets, a region's statistics equal
// to `chromo maps stats` on maps.exr (to 1e-6) and exported as CSV, channels
// switched quickly with the label and the value always matching, zoom linked
// across explorers, flags in categorical colours with a legend.
async function mapExplorerChecks(page, sessionId, mapsFile, cmMap) {
  const explorer = page.locator('.map-explorer').first();
  const started = performance.now();
  const steps = {};
  const step = (name) => { steps[name] = Math.round(performance.now() - started); };
  // Contrast: the model's range (log), then the subject's 1-99th percentile of the skin's cells.
  await explorer.getByLabel('Contrast', { exact: true }).selectOption('model');
  assert.equal(Number(await explorer.getByLabel('Low', { exact: true }).inputValue()), cmMap.model_min);
  assert.equal(Number(await explorer.getByLabel('High', { exact: true }).inputValue()), cmMap.model_max);
  assert.equal(await explorer.getByLabel('Log scale', { exact: true }).isChecked(), cmMap.log_scale);
  assert.ok(cmMap.unit.length > 0 && (await explorer.locator('.bar-title').textContent()).includes(cmMap.unit), 'unit beside the colour bar');
  const flagsMap = (await api('MapsService', 'GetMap', { session_id: sessionId, maps_file: mapsFile, channel: 'flags', max_width: 480 })).json;
  const skin = cmMap.values.map((v) => Math.fround(Number(v))).filter((v, i) => Number.isFinite(v) && [0, 4].includes(Number(flagsMap.values[i]))).sort((a, b) => a - b);
  const percentile = (p) => { const r = p / 100 * (skin.length - 1), b = Math.floor(r); return skin[b] + (skin[Math.min(b + 1, skin.length - 1)] - skin[b]) * (r - b); };
  await explorer.getByLabel('Contrast', { exact: true }).selectOption('percentile');
  assert.equal(Number(await explorer.getByLabel('Low', { exact: true }).inputValue()), Number(percentile(1).toPrecision(6)), 'p1 preset');
  assert.equal(Number(await explorer.getByLabel('High', { exact: true }).inputValue()), Number(percentile(99).toPrecision(6)), 'p99 preset');
  const ticks = (await explorer.locator('.colour-bar').getAttribute('data-ticks')).split(' ').map(Number);
  assert.ok(ticks.length >= 2 && ticks.every((t) => t >= percentile(1) - 1e-12 && t <= percentile(99) + 1e-12), `ticks ${ticks} inside the window`);

  step('contrast');
  // A region drawn with the mouse: the page's statistics are chromod's from maps.exr, equal to `chromo maps stats`'.
  const canvas = explorer.locator('.map-canvas');
  const box = await canvas.boundingBox();
  await page.mouse.move(box.x + box.width * 0.3, box.y + box.height * 0.35);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width * 0.5, box.y + box.height * 0.5, { steps: 4 });
  await page.mouse.move(box.x + box.width * 0.62, box.y + box.height * 0.66, { steps: 4 });
  await page.mouse.up();
  const statistics = explorer.locator('.region-statistics');
  await waitUntil(page, () => document.querySelector('.region-statistics[data-state="ready"]'), null, 60000, 'the region statistics');
  const shown = JSON.parse(await statistics.getAttribute('data-statistics'));
  const region = shown.region;
  const chromo = path.join(path.dirname(chromod), 'chromo');
  const cli = await new Promise((resolve, reject) => {
    const child = spawn(chromo, ['maps', 'stats', path.join(home, 'sessions', sessionId, mapsFile), '--region',
      `${region.x},${region.y},${region.width},${region.height}`, '--channel', 'Cm', '--json'], { stdio: ['ignore', 'pipe', 'inherit'] });
    let output = '';
    child.stdout.on('data', (data) => { output += data; });
    child.on('exit', (code) => (code === 0 ? resolve(JSON.parse(output).statistics[0]) : reject(new Error(`chromo maps stats exited ${code}`))));
  });
  assert.ok(Number(cli.pixels) > 100, `the region holds ${cli.pixels} skin pixels`);
  for (const key of ['mean', 'sd', 'min', 'p1', 'p5', 'p25', 'median', 'p75', 'p95', 'p99', 'max'])
    assert.ok(Math.abs(Number(shown[key]) - cli[key]) <= 1e-6, `region ${key}: page ${shown[key]}, chromo maps stats ${cli[key]}`);
  for (const key of ['pixels', 'flagged_pixels', 'outside_field_pixels', 'region_pixels']) assert.equal(Number(shown[key]), cli[key], `region ${key}`);
  const [download] = await Promise.all([page.waitForEvent('download'), explorer.getByRole('button', { name: 'Export CSV' }).click()]);
  const csv = (await (await download.createReadStream()).toArray()).join('').split('\n');
  const columns = csv[0].split(','), row = csv[1].split(',');
  assert.ok(Math.abs(Number(row[columns.indexOf('mean')]) - cli.mean) <= 1e-6, `CSV mean ${row[columns.indexOf('mean')]}`);
  console.log(`region ${region.width}x${region.height} at (${region.x}, ${region.y}): ${cli.pixels} pixels, Cm mean ${cli.mean.toPrecision(6)} ` +
    `SD ${cli.sd.toPrecision(3)}: page, CSV and chromo maps stats agree to 1e-6`);

  step('region');
  // Channels switched quickly: whenever a value shows, it is under its own channel's name.
  const sequence = ['Ch', 'Bm', 'Che', 'residual', 'Cm', 'Ch'];
  // Every state the explorer passes through, recorded in the page as it happens.
  await page.evaluate(() => {
    const section = document.querySelector('.map-explorer');
    const readout = section.querySelector('.map-value');
    window.mapObservations = [];
    const record = () => window.mapObservations.push({ channel: readout.dataset.channel ?? null, value: readout.dataset.value ?? null,
      cell: readout.dataset.cell, text: readout.textContent, state: section.dataset.state, selected: section.querySelector('select').value });
    new MutationObserver(record).observe(section, { attributes: true, childList: true, characterData: true, subtree: true });
  });
  const select = explorer.getByLabel('Map', { exact: true });
  for (const name of sequence) await select.selectOption(name);
  // And a channel chosen while another's request is under way (past the settling time): its reply is dropped.
  await select.selectOption('Bm');
  await page.waitForTimeout(250);
  await select.selectOption('Ch');
  const settled = () => document.querySelector('.map-explorer').dataset.state === 'ready' &&
    document.querySelector('.map-value').dataset.channel === 'Ch';
  await waitUntil(page, settled, null, 60000, 'the last channel').catch(async (error) => {
    const seen = await page.evaluate(() => ({ last: window.mapObservations.slice(-3), message: document.querySelector('.map-explorer .message').textContent,
      resources: performance.getEntriesByType('resource').slice(-8).map((e) => `${e.name.split('/').pop()} ${Math.round(e.startTime)}+${Math.round(e.duration)}`) }));
    const t0 = performance.now();
    const direct = await api('MapsService', 'GetMap', { session_id: sessionId, maps_file: mapsFile, channel: 'Ch', max_width: 480 });
    const now = await page.evaluate(() => Math.round(performance.now()));
    throw new Error(`${error.message}: ${JSON.stringify(seen)}; page now ${now}; direct GetMap ${direct.status} in ${Math.round(performance.now() - t0)} ms`);
  });
  const observations = await page.evaluate(() => window.mapObservations);
  const reference = {};  // GetMap of every channel a value was seen of
  for (const name of new Set(observations.map((o) => o.channel).filter((name) => name)))
    reference[name] = (await api('MapsService', 'GetMap', { session_id: sessionId, maps_file: mapsFile, channel: name, max_width: 480 })).json;
  const loadingSeen = observations.some((o) => o.state === 'loading' && o.text.startsWith(`loading ${o.selected}`));
  assert.ok(loadingSeen, 'a loading sign while a channel loads');
  for (const o of observations) {
    if (o.channel === null) continue;
    assert.ok(o.text.startsWith(`${o.channel} at pixel`), `label "${o.text}" under channel ${o.channel}`);
    assert.equal(o.channel, o.selected, `a ${o.channel} value shown while ${o.selected} is chosen`);
    const [x, y] = o.cell.split(',').map(Number);
    const expected = reference[o.channel].values[y * reference[o.channel].width + x];
    assert.equal(Number(o.value), Math.fround(Number(expected)), `${o.channel} value at cell ${o.cell}`);
  }
  const last = observations.at(-1);
  assert.equal(last.channel, 'Ch', 'the last channel asked for is the one shown');
  await waitUntil(page, () => document.querySelector('.region-statistics')?.dataset.channel === 'Ch', null, 60000, 'Ch statistics');
  console.log(`${sequence.length + 2} channel switches: ${observations.filter((o) => o.channel).length} values seen (${[...new Set(observations.map((o) => o.channel).filter((c) => c))]}), ` +
    'each under its own name');

  step('switches');
  // Zoom linked across explorers; flags in categorical colours with a legend.
  await page.getByRole('button', { name: 'Add a map beside' }).first().click();
  const second = page.locator('.map-explorer').nth(1);
  await waitUntil(page, () => document.querySelectorAll('.map-explorer[data-state="ready"]').length >= 2, null, 60000, 'a second map');
  // The scale bar (docs/maps.md "Scale bar"): this lab's camera has no pose, so
  // the 80 mm patch fills its rows and a map pixel is 80 mm / the maps' width.
  const pixelMm = 80 / cmMap.source_width;
  const scaleBar = async (zoom) => {
    const bar = JSON.parse(await explorer.locator('.map-canvas').getAttribute('data-scale-bar'));
    const canvasWidth = Number(await explorer.locator('.map-canvas').getAttribute('width'));
    const visibleMm = 80 / zoom;
    const expectedMm = [50, 20, 10, 5, 2, 1].find((mm) => mm <= visibleMm / 4);
    assert.equal(bar.mm, expectedMm, `scale bar at zoom ${zoom}: ${JSON.stringify(bar)}`);
    const expectedPx = expectedMm / pixelMm * canvasWidth / (cmMap.source_width / zoom);
    assert.ok(Math.abs(bar.canvasPx - expectedPx) < 1e-6, `scale bar at zoom ${zoom}: ${bar.canvasPx} canvas px, the geometry gives ${expectedPx}`);
    return bar;
  };
  const barWhole = await scaleBar(1);
  await explorer.getByRole('button', { name: 'Zoom in' }).click();
  assert.equal(await second.locator('.map-canvas').getAttribute('data-zoom'), '1.5', 'zoom linked to the second map');
  const barZoomed = await scaleBar(1.5);
  console.log(`scale bar: ${barWhole.mm} mm = ${barWhole.canvasPx} canvas px whole, ${barZoomed.mm} mm = ${barZoomed.canvasPx.toFixed(1)} px at 1.5x ` +
    `(${pixelMm} mm per map pixel)`);
  await second.getByLabel('Map', { exact: true }).selectOption('flags');
  await waitUntil(page, () => document.querySelectorAll('.map-explorer')[1].dataset.state === 'ready', null, 60000, 'the flags map');
  const legend = await second.locator('.legend li').allTextContents();
  assert.ok(legend.some((item) => item.includes('0: explained')), `flags legend: ${legend}`);
  assert.ok(legend.some((item) => item.includes('outside the lit field')), `flags legend: ${legend}`);
  await explorer.getByRole('button', { name: 'Whole map' }).click();
  assert.equal(await second.locator('.map-canvas').getAttribute('data-zoom'), '1');
  step('zoom_and_flags');
  figures.map_explorer_checks_ms = steps;
  console.log(`zoom linked across maps; flags legend ${legend.join(' | ')}`);
}

// Numbers people read: no "9.73e+3" on the page (the solver's own report,
// folded under "How the solver got there", is its prose, not the page's).
async function noExponents(page, name) {
  const text = await page.evaluate(() => {
    const main = document.querySelector('main').cloneNode(true);
    main.querySelectorAll('details').forEach((details) => details.remove());
    return main.textContent;
  });
  const exponents = text.match(/\b\d+(\.\d+)?e[+-]\d+/g) ?? [];
  assert.deepEqual(exponents, [], `${name}: numbers in exponent form`);
}

async function pressOn(page, locator, key) {
  await locator.focus();
  await page.keyboard.press(key);
}

// The Results page's frames table against GetSession's frames: the count,
// and every polarisation state expected among the lit frames.
async function checkFramesTable(page, sessionId, states) {
  const detail = await api('SessionService', 'GetSession', { id: sessionId, include_frames: true });
  const frames = detail.json.frames ?? [];
  await waitUntil(page, (count) => document.querySelector('[data-frames]')?.dataset.frames === String(count), frames.length,
    20000, `the frames table (${frames.length} frames)`);
  const table = page.locator('table').filter({ has: page.locator('caption', { hasText: 'Frames of the session' }) });
  assert.equal(await table.locator('tbody tr').count(), Math.min(frames.length, 500));
  const shown = new Set(await table.locator('tbody tr td:nth-child(6)').allTextContents());
  for (const state of states) assert.ok([...shown].some((text) => text.split(' + ').includes(state)), `no ${state} frame in ${[...shown]}`);
  console.log(`frames table: ${frames.length} frames, polarisation ${[...shown].join(', ')}`);
}

// The virtual lab with polariser banks and camera analysers (docs/polarisation.md):
// the plan is cross-polarised with a parallel D65' capture, the frames say
// so, and the results show optical highlights with the diffuse | surface |
// combined panel.
// Before and after (issue 42): on the later session's Results page, the
// earlier session of the same subject is offered; the comparison the page
// shows (verdict, both sessions' region statistics, the difference map under
// the cursor) is CompareSessions' for the same request.
async function comparisonChecks(page, afterId, beforeId) {
  const card = page.locator('section.comparison');
  await card.scrollIntoViewIfNeeded();
  await waitUntil(page, () => Number(document.querySelector('section.comparison select[name="compare_with"]')?.dataset.sessions ?? -1) >= 0,
    null, 20000, 'the sessions to compare with');
  assert.equal(await card.locator('select[name="compare_with"]').inputValue(), beforeId, 'the earlier session of the subject is offered');
  await waitUntil(page, () => document.querySelectorAll('section.comparison .region-field')[2]?.value !== '', null, 20000, 'the whole map as region');
  const started = performance.now();
  await card.getByRole('button', { name: 'Compare' }).click();
  await waitUntil(page, () => ['ready', 'error'].includes(document.querySelector('.comparison-output')?.dataset.state), null, 60000, 'the comparison');
  assert.equal(await card.locator('.comparison-output').getAttribute('data-state'), 'ready',
    `comparison failed: ${await card.locator('.comparison-message').textContent()}`);
  time('comparison_ms', started);
  // Both sessions' explorers below the difference map load on their own: once
  // they have, the layout stands still for the pointer.
  await waitUntil(page, () => document.querySelectorAll('.side-by-side .map-explorer[data-state="ready"]').length === 2, null, 60000,
    'both sessions side by side');
  const shown = JSON.parse(await card.locator('.comparison-output').getAttribute('data-comparison'));
  assert.equal(shown.request.session_id, beforeId, 'the older session is before');
  assert.equal(shown.request.after_session_id, afterId);
  const region = shown.request.region;
  const apiStarted = performance.now();
  const reply = (await api('MapsService', 'CompareSessions', shown.request)).json;
  time('compare_sessions_api_ms', apiStarted);
  assert.ok(reply.map_width > 0, JSON.stringify(reply).slice(0, 300));
  assert.equal(region.width, reply.before.source_width, 'the default region is the whole map');
  for (const key of ['median_difference', 'sigma_of_median', 'z', 'significant', 'compared_pixels', 'significant_pixels', 'region_compared_pixels', 'warped'])
    assert.deepEqual(shown.reply[key], reply[key], `${key}: page ${shown.reply[key]}, API ${reply[key]}`);
  for (const side of ['before', 'after'])
    for (const key of ['mean', 'median', 'sd', 'pixels']) assert.deepEqual(shown.reply[side][key], reply[side][key], `${side} ${key}`);
  const verdictText = await card.locator('.comparison-verdict').textContent();
  assert.ok(verdictText.includes(`z ${formatNumber(reply.z, 3)}:`) && verdictText.includes(`median change ${formatNumber(reply.median_difference, 4)} ±`),
    `verdict "${verdictText}" names the API's median change and z (${reply.median_difference}, ${reply.z})`);
  // The difference under the cursor is the API's at that cell (a compared one).
  const z = new Float32Array(Buffer.from(reply.z_f32, 'base64').buffer.slice(0));
  const difference = new Float32Array(Buffer.from(reply.difference_f32, 'base64').buffer.slice(0));
  const sigma = new Float32Array(Buffer.from(reply.sigma_f32, 'base64').buffer.slice(0));
  const target = z.findIndex((v, i) => Number.isFinite(v) && i % reply.map_width > reply.map_width / 3 && i > z.length / 3);
  assert.ok(target >= 0, 'no compared cell in the difference map');
  const canvas = card.locator('.difference-canvas');
  await canvas.scrollIntoViewIfNeeded();
  const box = await canvas.boundingBox();
  // A cell is one CSS pixel here: the pointer goes to whole pixels, and the
  // cell under it is the one those pixels fall in (as the page computes it).
  const [px, py] = [Math.round(box.x + (target % reply.map_width + 0.5) * box.width / reply.map_width),
    Math.round(box.y + (Math.floor(target / reply.map_width) + 0.5) * box.height / reply.map_height)];
  const [cx, cy] = [Math.floor((px - box.x) / box.width * reply.map_width), Math.floor((py - box.y) / box.height * reply.map_height)];
  const cell = cy * reply.map_width + cx;
  assert.ok(Number.isFinite(z[cell]), `cell ${cx},${cy} is not compared`);
  await page.mouse.move(px, py);
  const readout = card.locator('.difference-value');
  assert.equal(await readout.getAttribute('data-cell'), `${cx},${cy}`);
  assert.equal(Number(await readout.getAttribute('data-difference')), difference[cell], 'difference under the cursor');
  assert.equal(Number(await readout.getAttribute('data-sigma')), sigma[cell], 'its σ');
  assert.equal(Number(await readout.getAttribute('data-z')), z[cell], 'its z');
  // The difference itself and its σ per pixel, each on its own scale (± or 0 to
  // its 99th percentile over the compared pixels): the scale's ends and the
  // colour of the cell under the cursor are CompareSessions' numbers.
  for (const [layer, values, colourAt, symmetric] of [['difference', difference, diverging, true], ['sigma', sigma, viridis, false]]) {
    await card.locator('select[name="difference_layer"]').selectOption(layer);
    assert.equal(await canvas.getAttribute('data-layer'), layer);
    const end = percentileOfSorted(Float64Array.from(Array.from(values).map((v) => (symmetric ? Math.abs(v) : v)).filter(Number.isFinite)).sort(), 99);
    const [low, high] = (await card.locator('.comparison-output .difference-bar').getAttribute('data-range')).split(' ').map(Number);
    assert.deepEqual([low, high], [symmetric ? -end : 0, end], `${layer} scale`);
    const rgb = await canvas.evaluate((element, [x, y]) => [...element.getContext('2d').getImageData(x, y, 1, 1).data.slice(0, 3)],
      [2 * cx + 1, 2 * cy + 1]);
    assert.deepEqual(rgb, colourAt((values[cell] - low) / (high - low)), `${layer} colour at cell ${cx},${cy}`);
    console.log(`difference map as ${layer}: scale ${low.toPrecision(3)} to ${high.toPrecision(3)}, cell (${cx}, ${cy}) ${values[cell]} drawn ${rgb}`);
  }
  await card.locator('select[name="difference_layer"]').selectOption('z');
  // Both sessions side by side: an explorer each, showing its own session's
  // map (the value under the cursor is GetMap's of that session), zoom
  // linked between the two and not with the page's other explorers.
  const sides = card.locator('.side-by-side .map-explorer');
  for (const [i, id, file] of [[0, beforeId, shown.request.maps_file], [1, afterId, shown.request.after_maps_file]]) {
    assert.equal(await card.locator('.side-by-side [data-session]').nth(i).getAttribute('data-session'), id);
    const map = (await api('MapsService', 'GetMap', { session_id: id, maps_file: file, channel: 'Cm', max_width: 480 })).json;
    const sideCanvas = sides.nth(i).locator('.map-canvas');
    await sideCanvas.scrollIntoViewIfNeeded();
    const sideBox = await sideCanvas.boundingBox();
    await page.mouse.move(sideBox.x + sideBox.width / 2, sideBox.y + sideBox.height / 3);
    const [mx, my] = (await sides.nth(i).locator('.map-value').getAttribute('data-cell')).split(',').map(Number);
    assert.ok(Math.abs(mx - map.width / 2) <= 1 && Math.abs(my - map.height / 3) <= 1, `side ${i}: cell ${mx},${my} under the pointer`);
    const value = await sides.nth(i).locator('.map-value').getAttribute('data-value');
    assert.equal(Number(value), Math.fround(Number(map.values[my * map.width + mx])), `side ${i} (${id}): Cm at cell ${mx},${my}`);
  }
  await sides.nth(0).getByRole('button', { name: 'Zoom in' }).click();
  assert.equal(await sides.nth(1).locator('.map-canvas').getAttribute('data-zoom'), '1.5', 'zoom linked between the two sessions');
  assert.equal(await page.locator('.map-explorer .map-canvas').first().getAttribute('data-zoom'), '1', 'the page\'s own explorer moved too');
  console.log('both sessions side by side: each explorer shows its own session\'s Cm (GetMap\'s), zoom linked between them');
  console.log(`before/after ${beforeId} → ${afterId}: ${reply.channel} median change ${reply.median_difference} ± ${reply.sigma_of_median} ` +
    `(z ${reply.z}, ${reply.significant ? 'changed' : 'unchanged'}), ${reply.significant_pixels} of ${reply.compared_pixels} pixels beyond ` +
    `${reply.threshold_sigma} sigma, warped ${reply.warped}: page equals CompareSessions; ${figures.comparison_ms} ms`);
  await card.screenshot({ path: path.join(screenshotDir, 'results-comparison.png') });
}

async function polarisedSession(page, port, earlierSessionId) {
  await stopDaemon();
  writeFileSync(path.join(home, 'chromod.json'), JSON.stringify({ token: TOKEN, web_dir: webDir, virtual_lab: { polarisers: true } }));
  origin = await startDaemon(port);
  await page.locator('#connection').waitFor({ state: 'hidden', timeout: 30000 });
  await page.getByLabel('Token').fill(TOKEN);
  await page.keyboard.press('Enter');
  await page.getByRole('heading', { name: 'Live' }).waitFor();
  const login = await fetch(`${origin}/login`, { method: 'POST', headers: { 'Content-Type': 'application/json', Origin: origin },
    body: JSON.stringify({ token: TOKEN }) });
  assert.equal(login.status, 200);
  cookie = login.headers.get('set-cookie').split(';')[0];
  await pressOn(page, page.getByRole('link', { name: 'Sessions' }), 'Enter');
  await page.getByRole('cell', { name: 'subject_d65_parallel' }).first().waitFor({ timeout: 10000 });
  const planStates = new Set(await page.locator('.plan tbody tr td:nth-child(5)').allTextContents());
  assert.ok(planStates.has('cross') && planStates.has('parallel'), `the polarised plan's states: ${[...planStates]}`);
  const started = performance.now();
  const operation = await api('SessionService', 'StartSession', { standard: true, subject: 'browser test forearm', exposure_us: 10000 });
  assert.equal(operation.status, 200, JSON.stringify(operation.json));
  const id = operation.json.id;
  for (let state = ''; ; await new Promise((resolve) => setTimeout(resolve, 500))) {
    state = (await api('OperationService', 'GetOperation', { id })).json.state;
    if (!['OPERATION_STATE_RUNNING', 'OPERATION_STATE_PENDING'].includes(state)) {
      assert.equal(state, 'OPERATION_STATE_SUCCEEDED', `polarised session ${id} ended ${state}`);
      break;
    }
  }
  time('polarised_session_ms', started);
  await page.goto(`${origin}/#results/${encodeURIComponent(id)}`);
  await page.getByText(/results available/).waitFor({ timeout: 30000 });
  const results = await api('ResultsService', 'GetResults', { session_id: id });
  const camera = results.json.cameras[0];
  assert.equal(camera.summary.highlight_detection, 'optical');
  const highlights = page.locator(`section[data-camera="${camera.camera}"] .highlights`);
  assert.equal(await highlights.getAttribute('data-detection'), 'optical');
  assert.match(await highlights.textContent(), new RegExp(`optical \\(parallel − cross\\): ${camera.summary.highlight_pixels ?? 0} pixels flagged`));
  await waitUntil(page, () => { const image = document.querySelector('.highlights img'); return image?.complete && image.naturalWidth > 0; },
    null, 20000, 'the diffuse | surface | combined panel');
  await checkFramesTable(page, id, ['cross', 'parallel']);
  await page.screenshot({ path: path.join(screenshotDir, 'results-polarised.png'), fullPage: true });
  console.log(`polarised session ${id}: highlights optical, ${camera.summary.highlight_pixels ?? 0} pixels flagged; ${figures.polarised_session_ms} ms`);
  await comparisonChecks(page, id, earlierSessionId);
}

async function main() {
  origin = await startDaemon();
  const port = new URL(origin).port;
  console.log(`chromod web view on ${origin}`);

  // A cross-origin POST is refused, even with a valid cookie.
  const login = await fetch(`${origin}/login`, { method: 'POST', headers: { 'Content-Type': 'application/json', Origin: origin },
    body: JSON.stringify({ token: TOKEN }) });
  assert.equal(login.status, 200);
  cookie = login.headers.get('set-cookie').split(';')[0];
  assert.match(login.headers.get('set-cookie'), /HttpOnly/i);
  assert.match(login.headers.get('set-cookie'), /SameSite=Strict/i);
  const crossOrigin = await api('LedService', 'GetLedState', {}, { Origin: 'http://evil.example' });
  assert.equal(crossOrigin.status, 403, 'a cross-origin POST must be refused');
  console.log(`cross-origin POST refused: ${crossOrigin.status} ${crossOrigin.json.error}`);

  browser = await playwright.chromium.launch({ executablePath: chromium, headless: true, args: ['--no-sandbox'] });
  const context = await browser.newContext({ viewport: { width: 1280, height: 800 } });
  const page = await context.newPage();
  page.on('pageerror', (error) => console.log(`[page error] ${error.message}`));
  // What a CI failure needs to be understood: requests the browser saw fail
  // and the page's own warnings (the connection state flipping).
  page.on('requestfailed', (request) => console.log(`[request failed] ${request.method()} ${request.url()}: ${request.failure()?.errorText}`));
  page.on('console', (message) => { if (message.type() === 'warning') console.log(`[page warning] ${message.text()}`); });
  await page.goto(origin);

  // A wrong token is refused, the right one logs in (keyboard: type, Enter).
  await page.getByLabel('Token').fill('not-the-token-at-all');
  await page.keyboard.press('Enter');
  await page.getByText(/wrong token/).waitFor();
  await page.screenshot({ path: path.join(screenshotDir, 'login.png') });
  await checkKeyboardAndWidth(page, 'log-in');
  await page.getByLabel('Token').fill(TOKEN);
  await page.keyboard.press('Enter');
  await page.getByRole('heading', { name: 'Live' }).waitFor();

  // An inline script is refused by the Content-Security-Policy.
  const csp = await page.evaluate(() => new Promise((resolve) => {
    let violated = false;
    document.addEventListener('securitypolicyviolation', () => { violated = true; });
    const script = document.createElement('script');
    script.textContent = 'window.inlineScriptRan = true;';
    document.body.append(script);
    setTimeout(() => resolve({ violated, ran: window.inlineScriptRan === true }), 300);
  }));
  assert.equal(csp.ran, false, 'an inline script ran');
  assert.equal(csp.violated, true, 'no securitypolicyviolation for the inline script');
  console.log('inline script refused by CSP (securitypolicyviolation fired)');

  // Live: the picture changes when the LED state changes (set from the page).
  await waitForNewFrames(page, 2);
  const setLeds = async (level, enabled) => {
    for (const label of ['W57 (cool white)', 'W40 (neutral white)', 'W27 (warm white)', 'Red', 'Green', 'Blue'])
      await page.getByLabel(label, { exact: true }).fill(String(level));
    await page.getByLabel('Output enabled').setChecked(enabled);
    await pressOn(page, page.getByRole('button', { name: 'Set LEDs' }), 'Enter');
    await page.getByText('LED state applied').waitFor();
    await waitForNewFrames(page, 3);
  };
  await setLeds(0, false);
  const dark = await meanBrightness(page);
  await setLeds(0.55, true);
  const lit = await meanBrightness(page);
  console.log(`live picture mean brightness: LEDs off ${dark.toFixed(1)}, all at 0.55 ${lit.toFixed(1)}`);
  assert.ok(lit - dark > 5, `the live picture did not change with the LED state (${dark} → ${lit})`);
  const ledState = await api('LedService', 'GetLedState', {});
  // The controller quantises to 16-bit PWM (0.55 → 0.5499961…); the inputs show the level typed, not its float noise.
  assert.ok(Math.abs(ledState.json.applied.drive.w57 - 0.55) <= 1 / 65535, `applied w57 ${ledState.json.applied.drive.w57}`);
  const driveInputs = await page.locator('form.leds input[type="number"]').evaluateAll((inputs) => inputs.map((input) => input.value));
  assert.deepEqual(driveInputs, Array(6).fill('0.55'), `the drive inputs after the API answered ${ledState.json.applied.drive.w57}`);
  // Camera settings from the page: the exposure the API then reports.
  await page.getByLabel('Exposure (µs)').fill('5000');
  await pressOn(page, page.getByRole('button', { name: 'Apply camera settings' }), 'Space');
  await waitUntil(page, () => document.querySelector('section.camera .message.info, section.camera form + .message.error'), null, 30000,
    'the camera settings answer');
  const cameraAnswer = await page.locator('section.camera form + .message').textContent();
  assert.match(cameraAnswer, /applied: exposure 5,000 µs/, `camera settings from the page: ${cameraAnswer}`);
  const cameras = await api('CameraService', 'ListCameras', {});
  assert.equal(cameras.json.cameras[0].exposure_us, 5000);
  await waitUntil(page, () => document.querySelector('.facts')?.textContent.includes('5,000 µs'), null, 10000, 'a frame at 5,000 µs');
  await page.screenshot({ path: path.join(screenshotDir, 'live.png') });
  await noExponents(page, 'live');
  await checkKeyboardAndWidth(page, 'live');

  // Devices and calibration: navigate by keyboard, calibrate from the page.
  await pressOn(page, page.getByRole('link', { name: 'Devices and calibration' }), 'Enter');
  await page.getByRole('heading', { name: 'Devices', exact: true }).waitFor();
  const devices = await api('DeviceService', 'ListDevices', {});
  for (const device of devices.json.devices) await page.getByRole('cell', { name: device.name, exact: true }).first().waitFor();
  await page.getByLabel(/Drive levels \(comma-separated/).fill('0.5, 1');
  let started = performance.now();
  await pressOn(page, page.getByRole('button', { name: 'Start calibration' }), 'Enter');
  await page.waitForSelector('.operation[data-state="OPERATION_STATE_SUCCEEDED"]', { timeout: 300000 });
  time('calibration_ms', started);
  await page.waitForSelector('.mix[data-target="d65"]', { timeout: 60000 });
  // Each figure of merit to its resolution, as the API has it (no "1.001e-16" for a Δu′v′ of zero).
  for (const target of ['d65', 'w57+blue']) {
    const mix = await api('CalibrationService', 'SolveMix', { target, objective: 'MIX_OBJECTIVE_CAMERA', hold_chromaticity: target === 'd65' });
    for (const [name, value] of Object.entries(mix.json.figures)) {
      const row = page.locator(`.mix[data-target="${target}"] tr[data-figure="${name}"]`);
      const decimals = Number(await row.getAttribute('data-decimals'));
      const shown = (await row.locator('td').nth(1).textContent()).replaceAll(',', '').split(' ')[0];
      assert.match(shown, decimals ? new RegExp(`^-?\\d+\\.\\d{${decimals}}$`) : /^-?\d+$/, `${target} figure ${name}: "${shown}"`);
      assert.ok(Math.abs(Number(shown) - Number(value)) <= 0.5 * 10 ** -decimals + 1e-12, `${target} figure ${name}: page ${shown}, API ${value}`);
    }
  }
  await page.screenshot({ path: path.join(screenshotDir, 'devices.png'), fullPage: true });
  await noExponents(page, 'devices');
  await checkKeyboardAndWidth(page, 'devices');

  // Sessions: the standard session from the page; interactions timed during it.
  await pressOn(page, page.getByRole('link', { name: 'Sessions' }), 'Enter');
  await page.getByRole('heading', { name: 'Start a session' }).waitFor();
  await page.getByRole('cell', { name: 'subject_d65' }).first().waitFor();
  // The plan's polarisation per step: this sphere has no polariser banks, so
  // every lit step is unpolarised; the polarised plan can be shown, but as
  // soon as it is chosen the page says why chromod would refuse it (naming
  // the missing banks, as StartSession does) and Start is disabled.
  const subjectRow = await page.locator('.plan tr').filter({ has: page.getByRole('cell', { name: 'subject_d65', exact: true }) })
    .first().locator('td').allTextContents();
  assert.ok(subjectRow.includes('unpolarised'), `subject_d65's row: ${subjectRow.join(' | ')}`);
  const sessionsBefore = (await api('SessionService', 'ListSessions', {})).json.sessions?.length ?? 0;
  await page.getByLabel('Polarisation', { exact: true }).selectOption('POLARISED_PLAN_ON');
  await page.getByRole('cell', { name: 'subject_d65_parallel', exact: true }).waitFor({ timeout: 10000 });
  const refusal = page.locator('.start-session .plan-refusal');
  await refusal.filter({ hasText: /has no polariser banks/ }).waitFor({ timeout: 10000 });
  assert.ok(await page.getByRole('button', { name: 'Start session' }).isDisabled(), 'Start enabled for a plan chromod refuses');
  const refused = await api('SessionService', 'StartSession', { standard: true, polarised: 'POLARISED_PLAN_ON' });
  assert.equal(refused.status, 400);
  assert.ok((await refusal.textContent()).endsWith(refused.json.error), `the page's reason "${await refusal.textContent()}", StartSession's "${refused.json.error}"`);
  console.log(`polarised plan on an unpolarised sphere, on choosing it: "${await refusal.textContent()}"; Start disabled`);
  await page.getByLabel('Subject', { exact: true }).press('Enter');  // a form's implicit submission sends nothing either
  assert.equal((await api('SessionService', 'ListSessions', {})).json.sessions?.length ?? 0, sessionsBefore, 'a refused session was listed');
  await page.getByLabel('Polarisation', { exact: true }).selectOption('POLARISED_PLAN_CONFIGURED');
  await refusal.waitFor({ state: 'hidden', timeout: 10000 });
  assert.ok(await page.getByRole('button', { name: 'Start session' }).isEnabled(), 'Start still disabled for a plan that runs');
  await page.getByRole('cell', { name: 'subject_d65_parallel', exact: true }).waitFor({ state: 'detached', timeout: 10000 });
  await page.getByRole('cell', { name: 'subject_d65' }).first().waitFor();
  await page.getByLabel('Subject', { exact: true }).fill('browser test forearm');
  await page.getByLabel('Exposure (µs)', { exact: true }).fill('10000');
  // One interaction: Refresh the list, until its answer is drawn (ms).
  const refreshMs = async () => {
    const clicked = performance.now();
    const answered = page.waitForResponse((reply) => reply.url().endsWith('/api/SessionService/ListSessions'));
    await pressOn(page, page.getByRole('button', { name: 'Refresh the list' }), 'Enter');
    await answered;
    await page.evaluate(() => new Promise((resolve) => requestAnimationFrame(() => resolve())));
    return performance.now() - clicked;
  };
  // The same interaction with nothing estimating, on this machine at this
  // moment: the basis of the bound below, so that a machine loaded by other
  // tests (the suite runs this test beside them) widens it.
  const idle = [];
  for (let i = 0; i < 3; ++i) idle.push(await refreshMs());
  idle.sort((a, b) => a - b);
  started = performance.now();
  await pressOn(page, page.getByRole('button', { name: 'Start session' }), 'Enter');
  await page.getByText(/session .* started/).waitFor();
  const sessionId = await page.locator('.operation').getAttribute('data-operation-id');
  const latencies = [];
  while (true) {
    const state = await page.locator('.operation').getAttribute('data-state');
    if (!['OPERATION_STATE_RUNNING', 'OPERATION_STATE_PENDING'].includes(state)) break;
    const operation = await api('OperationService', 'GetOperation', { id: sessionId });
    const estimating = Number(operation.json.counters?.estimated ?? 0) > 0;
    const ms = await refreshMs();
    if (estimating) latencies.push(ms);
    await page.waitForTimeout(500);
  }
  time('session_ms', started);
  console.log(`session ${sessionId} from the page: ${figures.session_ms} ms`);
  assert.equal(await page.locator('.operation').getAttribute('data-state'), 'OPERATION_STATE_SUCCEEDED');
  latencies.sort((a, b) => a - b);
  if (latencies.length) {
    figures.interaction_during_estimation_ms = { count: latencies.length, median: Math.round(latencies[latencies.length >> 1]),
      max: Math.round(latencies.at(-1)), idle_median: Math.round(idle[1]) };
    console.log(`interactions during estimation: ${JSON.stringify(figures.interaction_during_estimation_ms)} ms (target 200 ms)`);
    // 2 s, or 10x the idle interaction on a machine slow enough to need more:
    // an estimator holding the daemon's web threads shows as seconds (a stage
    // of the 640x480 estimate), beyond either.
    const boundMs = Math.max(2000, 10 * idle[1]);
    assert.ok(latencies.at(-1) < boundMs,
      `an interaction during estimation took ${Math.round(latencies.at(-1))} ms (bound ${Math.round(boundMs)} ms: 2 s or 10x the idle ${Math.round(idle[1])} ms)`);
  }
  await page.getByRole('link', { name: `Results of ${sessionId}` }).waitFor();
  await page.screenshot({ path: path.join(screenshotDir, 'sessions.png'), fullPage: true });
  await noExponents(page, 'sessions');
  await checkKeyboardAndWidth(page, 'sessions');

  // Results: the page's figures are the API's; relight one.
  await pressOn(page, page.getByRole('link', { name: `Results of ${sessionId}` }), 'Enter');
  await page.getByText(/results available/).waitFor({ timeout: 30000 });
  const results = await api('ResultsService', 'GetResults', { session_id: sessionId });
  assert.equal(results.json.state, 'RESULTS_STATE_AVAILABLE');
  for (const camera of results.json.cameras) {
    for (const [illuminant, statistics] of Object.entries(camera.summary.relit_delta_e94)) {
      // One read of the DOM (the row and its cells together), so a table being
      // rebuilt cannot hand back a row without its cells.
      const relitRow = ([cameraName, name]) => [...document.querySelectorAll(`section[data-camera="${cameraName}"] tr`)]
        .map((row) => [...row.cells].map((cell) => cell.textContent)).find((cells) => cells[0] === name) ?? null;
      await waitUntil(page, relitRow, [camera.camera, illuminant], 10000, `the ${camera.camera} ${illuminant} row`);
      const cells = await page.evaluate(relitRow, [camera.camera, illuminant]);
      assert.equal(Number(cells[1]), Number(statistics.mean.toPrecision(3)), `${camera.camera} ${illuminant} mean ΔE94`);
      assert.equal(Number(cells[3]), Number(statistics.p95.toPrecision(3)), `${camera.camera} ${illuminant} p95 ΔE94`);
    }
    console.log(`results of ${camera.camera}: page figures equal the API's (${Object.keys(camera.summary.relit_delta_e94).join(', ')})`);
  }
  // How highlights were found, and the session's frames with their polarisation.
  const firstCamera = results.json.cameras[0];
  const highlights = page.locator(`section[data-camera="${firstCamera.camera}"] .highlights`);
  assert.equal(await highlights.getAttribute('data-detection'), 'heuristic');
  assert.match(await highlights.textContent(), new RegExp(`: ${firstCamera.summary.highlight_pixels ?? 0} pixels flagged specular`));
  await checkFramesTable(page, sessionId, ['unpolarised']);
  // The files the page links to come from GET /api/files, as the API names them.
  const reportPath = results.json.cameras[0].report_file.slice(results.json.folder.length + 1);
  const report = await fetch(`${origin}/api/files/${sessionId}/${reportPath}`, { headers: { Cookie: cookie } });
  assert.equal(report.status, 200, `GET /api/files/${sessionId}/${reportPath}`);
  await page.locator(`a[href$="${reportPath}"]`).first().waitFor();
  // The previews load lazily, as they come near the view: look at each, as a
  // reader scrolling down would (else a taller explorer above keeps them unloaded).
  for (const preview of await page.locator('.map img').all()) await preview.scrollIntoViewIfNeeded();
  await waitUntil(page, () => [...document.querySelectorAll('.map img')].every((image) => image.complete && image.naturalWidth > 0),
    null, 20000, 'the map previews');
  console.log(`map previews shown (${await page.locator('.map img').count()}), files linked`);
  // The value under the cursor is GetMap's value of that cell: by keyboard
  // (arrow keys on the focused map) and by mouse.
  const mapsFile = results.json.cameras[0].maps_file.slice(results.json.folder.length + 1);
  const cmMap = await api('MapsService', 'GetMap', { session_id: sessionId, maps_file: mapsFile, channel: 'Cm', max_width: 480 });
  assert.equal(cmMap.status, 200, JSON.stringify(cmMap.json));
  const canvas = page.locator('.map-canvas').first();
  await waitUntil(page, () => document.querySelector('.map-canvas[data-channel="Cm"]') !== null, null, 20000, 'the Cm map');
  await canvas.focus();
  for (let i = 0; i < 5; ++i) await page.keyboard.press('ArrowRight');
  for (let i = 0; i < 3; ++i) await page.keyboard.press('ArrowDown');
  const byKeyboard = await page.locator('.map-value').first().getAttribute('data-value');
  assert.equal(Number(byKeyboard), Math.fround(Number(cmMap.json.values[3 * cmMap.json.width + 5])), 'keyboard cursor (5, 3): page and GetMap differ');
  const box = await canvas.boundingBox();
  const [cx, cy] = [Math.floor(cmMap.json.width / 2), Math.floor(cmMap.json.height / 2)];
  await page.mouse.move(box.x + (cx + 0.5) * box.width / cmMap.json.width, box.y + (cy + 0.5) * box.height / cmMap.json.height);
  const byMouse = await page.locator('.map-value').first().getAttribute('data-value');
  assert.equal(Number(byMouse), Math.fround(Number(cmMap.json.values[cy * cmMap.json.width + cx])), 'mouse cursor at the centre: page and GetMap differ');
  console.log(`value under the cursor equals GetMap's (Cm ${byKeyboard} at cell 5,3; ${byMouse} at the centre)`);
  await mapExplorerChecks(page, sessionId, mapsFile, cmMap.json);
  await page.getByLabel('Illuminant').selectOption('D65');
  started = performance.now();
  await pressOn(page, page.getByRole('button', { name: 'Relight' }), 'Enter');
  await waitUntil(page, () => document.querySelector('.relight-output[data-relit]') ||
    document.querySelector('.relight-message.error'), null, 120000, 'the relit figures');
  const relightError = await page.locator('.relight-message.error').count();
  assert.equal(relightError, 0, `relight refused: ${relightError && await page.locator('.relight-message').textContent()}`);
  time('relight_ms', started);
  const shownRelight = JSON.parse(await page.locator('.relight-output').getAttribute('data-relit'));
  const camera = results.json.cameras[0];
  const relight = await api('MapsService', 'Relight', { session_id: sessionId, illuminant: 'D65',
    maps_file: camera.maps_file.slice(results.json.folder.length + 1) });
  assert.equal(relight.status, 200, JSON.stringify(relight.json));
  assert.deepEqual(shownRelight, { relit_pixels: relight.json.relit_pixels, width: relight.json.width, height: relight.json.height,
    compared: false, photo_delta_e94: null }, 'relit under D65: page and API differ');
  assert.ok(Number(relight.json.relit_pixels) > 0);
  await page.getByText(`relit ${relight.json.relit_pixels} of ${relight.json.width}×${relight.json.height} pixels under`).waitFor();
  console.log(`relit under D65: ${relight.json.relit_pixels} of ${relight.json.width}x${relight.json.height} pixels (page and API agree)`);
  await page.screenshot({ path: path.join(screenshotDir, 'results.png'), fullPage: true });
  await checkKeyboardAndWidth(page, 'results');

  // The daemon going away is shown, and the page recovers when it returns.
  await pressOn(page, page.getByRole('link', { name: 'Live' }), 'Enter');
  await stopDaemon();
  started = performance.now();
  await page.locator('#connection').filter({ hasText: 'does not answer' }).waitFor({ timeout: 15000 });
  time('daemon_gone_shown_ms', started);
  await page.screenshot({ path: path.join(screenshotDir, 'daemon-away.png') });
  origin = await startDaemon(port);
  started = performance.now();
  await page.locator('#connection').waitFor({ state: 'hidden', timeout: 30000 });
  time('daemon_back_shown_ms', started);
  // The restarted daemon knows no log-ins: the page asks again, then streams.
  await page.getByLabel('Token').fill(TOKEN);
  await page.keyboard.press('Enter');
  await page.getByRole('heading', { name: 'Live' }).waitFor();
  await waitForNewFrames(page, 2);
  console.log('daemon away shown and recovered');

  await polarisedSession(page, port, sessionId);

  await browser.close();
  console.log(`timings: ${JSON.stringify(figures)}`);
}

await runMain(main, async () => {
  if (browser) await browser.close().catch(() => {});
  await stopDaemon();
  rmSync(home, { recursive: true, force: true });
});
