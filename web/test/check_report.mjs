// Opens a report in headless Chromium and checks that it works offline.
//
//   node test/check_report.mjs path/to/report.html [--screenshot out.png] [--expect-plots K]
//                              [--expect-scale MIN,MAX]
//
// Fails (exit 1) on: a console error or page error; a request to anything but
// the report file itself; window.wbmReady not set within 20 s; a blank 3D
// view; fewer drawn uPlot charts than plots in the data (exactly K with
// --expect-plots); a value axis that does not hold its plot's values, or that
// spreads a flat plot over more than max(2, 4 |value|); a 3D image that does
// not change when the time slider moves to the end; a body origin out of the 3D view at the
// first, middle or last sample; with --expect-scale, a scale of the drawn robot (links, spheres,
// arrows: window.wbmDrawingScale) outside [MIN, MAX]. The screenshot (full page)
// is taken with the slider at the middle.

import { chromium } from 'playwright-core';
import { existsSync } from 'node:fs';
import { resolve } from 'node:path';
import { pathToFileURL } from 'node:url';

const CHROMIUM = '/usr/bin/chromium';
const READY_TIMEOUT_MS = 20000;
const MIN_DISTINCT_COLOURS = 16;
const MIN_NON_BACKGROUND = 0.02;

function usage(message) {
  if (message) console.error(`check_report.mjs: ${message}`);
  console.error('usage: node test/check_report.mjs REPORT.html [--screenshot OUT.png] [--expect-plots K] ' +
    '[--expect-scale MIN,MAX]');
  process.exit(2);
}

function parseArgs(argv) {
  const options = { report: null, screenshot: null, expectPlots: null, expectScale: null };
  for (let i = 0; i < argv.length; i++) {
    const arg = argv[i];
    if (arg === '--screenshot') options.screenshot = argv[++i] ?? usage('--screenshot needs a file name');
    else if (arg === '--expect-plots') {
      options.expectPlots = Number(argv[++i]);
      if (!Number.isInteger(options.expectPlots) || options.expectPlots < 0) usage('--expect-plots needs a count');
    } else if (arg === '--expect-scale') {
      const range = String(argv[++i] ?? '').split(',').map(Number);
      if (range.length !== 2 || !range.every(Number.isFinite) || range[0] > range[1]) usage('--expect-scale needs MIN,MAX');
      options.expectScale = range;
    } else if (arg.startsWith('--')) usage(`unknown option ${arg}`);
    else if (options.report === null) options.report = arg;
    else usage(`unexpected argument ${arg}`);
  }
  if (options.report === null) usage('no report given');
  return options;
}

const options = parseArgs(process.argv.slice(2));
const reportPath = resolve(options.report);
if (!existsSync(reportPath)) usage(`${reportPath} does not exist`);
const reportUrl = pathToFileURL(reportPath).href;

const results = [];
function record(name, ok, detail) {
  results.push(ok);
  console.log(`${ok ? 'PASS' : 'FAIL'} ${name}: ${detail}`);
}

async function runCheck(name, fn) {
  try {
    const [ok, detail] = await fn();
    record(name, ok, detail);
  } catch (err) {
    record(name, false, err.message.split('\n')[0]);
  }
}

// Runs in the page: statistics of the 3D view's pixels. With `keep`, stores
// the pixels for a later comparison; with `compare`, counts changed pixels.
function viewPixels({ keep, compare }) {
  const gl = document.querySelector('#view canvas');
  if (!gl) throw new Error('no canvas in #view');
  const canvas = document.createElement('canvas');
  canvas.width = gl.width;
  canvas.height = gl.height;
  const ctx = canvas.getContext('2d');
  ctx.drawImage(gl, 0, 0);
  const pixels = new Uint32Array(ctx.getImageData(0, 0, canvas.width, canvas.height).data.buffer);
  const counts = new Map();
  for (const p of pixels) counts.set(p, (counts.get(p) || 0) + 1);
  let background = 0;
  let backgroundCount = -1;
  for (const [colour, n] of counts) {
    if (n > backgroundCount) {
      background = colour;
      backgroundCount = n;
    }
  }
  const stats = {
    width: canvas.width,
    height: canvas.height,
    distinct: counts.size,
    nonBackground: 1 - backgroundCount / pixels.length,
  };
  if (compare) {
    const before = window.__wbmCheckPixels;
    let changed = 0;
    if (before && before.length === pixels.length) {
      for (let i = 0; i < pixels.length; i++) if (pixels[i] !== before[i]) changed++;
    } else {
      changed = pixels.length;
    }
    stats.changed = changed;
  }
  if (keep) window.__wbmCheckPixels = pixels;
  return stats;
}

// Runs in the page: for each uPlot chart, its non-background and coloured
// (series-like) pixel counts, plus whether its plot has any non-null value.
function chartPixels() {
  const data = JSON.parse(document.getElementById('wbm-data').textContent);
  const plots = Array.isArray(data.plots) ? data.plots : [];
  const charts = [...document.querySelectorAll('.uplot')].map((el, i) => {
    const canvas = el.querySelector('canvas');
    if (!canvas || canvas.width === 0 || canvas.height === 0) return { nonBackground: 0, coloured: 0 };
    const rgba = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    let nonBackground = 0;
    let coloured = 0;
    for (let p = 0; p < rgba.length; p += 4) {
      if (rgba[p + 3] === 0) continue;
      nonBackground++;
      const max = Math.max(rgba[p], rgba[p + 1], rgba[p + 2]);
      const min = Math.min(rgba[p], rgba[p + 1], rgba[p + 2]);
      if (rgba[p + 3] > 100 && max - min > 40) coloured++;
    }
    const plot = plots[i];
    const hasValues = Boolean(plot && plot.series.some((s) => s.values.some((v) => v !== null)));
    return { nonBackground, coloured, hasValues, title: plot ? plot.title : '?' };
  });
  return { dataPlots: plots.length, charts };
}

function moveSlider(where) {
  const slider = document.getElementById('time-slider');
  if (!slider) throw new Error('no #time-slider');
  const max = Number(slider.max);
  slider.value = String(where === 'end' ? max : Math.floor(max / 2));
  slider.dispatchEvent(new Event('input', { bubbles: true }));
  return new Promise((done) => requestAnimationFrame(() => requestAnimationFrame(() => done(slider.value))));
}

const pageErrors = [];
const foreignRequests = [];
let onPageError = () => {};
const firstPageError = new Promise((resolve) => { onPageError = resolve; });

function pageError(message) {
  pageErrors.push(message.split('\n')[0]);
  onPageError(message);
}

let browser;
try {
  browser = await chromium.launch({
    executablePath: CHROMIUM,
    headless: true,
    args: [
      '--no-sandbox',
      '--enable-unsafe-swiftshader',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
    ],
  });
} catch (err) {
  record('launch chromium', false, err.message.split('\n')[0]);
  console.log('0 passed, 1 failed');
  process.exit(1);
}

try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  page.on('console', (msg) => {
    if (msg.type() === 'error') pageError(`console.error: ${msg.text()}`);
  });
  page.on('pageerror', (err) => pageError(`page error: ${err.message}`));
  page.on('request', (req) => {
    if (req.url().split('#')[0] !== reportUrl) foreignRequests.push(req.url());
  });

  const started = Date.now();
  await runCheck('load', async () => {
    await page.goto(reportUrl, { waitUntil: 'load', timeout: READY_TIMEOUT_MS });
    return [true, `${reportUrl} in ${Date.now() - started} ms`];
  });

  await runCheck('wbmReady', async () => {
    const ready = page.waitForFunction(() => window.wbmReady === true, null, {
      timeout: Math.max(READY_TIMEOUT_MS - (Date.now() - started), 1),
    }).then(() => 'ready', () => 'timeout');
    const errorFirst = firstPageError.then(() => 'error');
    const outcome = await Promise.race([ready, errorFirst]);
    if (outcome === 'ready') return [true, `set after ${Date.now() - started} ms`];
    if (outcome === 'error') return [false, 'not set: the page reported an error (see below)'];
    return [false, `window.wbmReady was not set within ${READY_TIMEOUT_MS / 1000} s`];
  });

  await runCheck('3D view drawn', async () => {
    const s = await page.evaluate(viewPixels, { keep: true, compare: false });
    const ok = s.distinct >= MIN_DISTINCT_COLOURS && s.nonBackground >= MIN_NON_BACKGROUND;
    return [ok, `${s.width}x${s.height}, ${s.distinct} distinct colours (need ${MIN_DISTINCT_COLOURS}), ` +
      `${(100 * s.nonBackground).toFixed(1)}% non-background pixels (need ${100 * MIN_NON_BACKGROUND}%)`];
  });

  await runCheck('plots drawn', async () => {
    const { dataPlots, charts } = await page.evaluate(chartPixels);
    const expected = options.expectPlots ?? dataPlots;
    const drawn = charts.filter((c) => c.nonBackground > 0 && (!c.hasValues || c.coloured > 0));
    const problems = charts
      .map((c, i) => (drawn.includes(c) ? null : `chart ${i} ("${c.title}") looks empty`))
      .filter(Boolean);
    const countOk = options.expectPlots === null ? drawn.length >= expected : drawn.length === expected;
    const detail = `${drawn.length} of ${charts.length} uPlot charts drawn, ${expected} expected` +
      (options.expectPlots === null ? ` (plots in the data)` : ` (--expect-plots)`) +
      (problems.length ? `; ${problems.join('; ')}` : '');
    return [countOk && problems.length === 0, detail];
  });

  await runCheck('value axes fit the data', async () => {
    const ranges = await page.evaluate(() => window.wbmPlotValueRanges());
    const data = await page.evaluate(() => JSON.parse(document.getElementById('wbm-data').textContent));
    const problems = [];
    let flat = 0;
    (data.plots || []).forEach((plot, i) => {
      let low = Infinity;
      let high = -Infinity;
      for (const s of plot.series) {
        for (const v of s.values) {
          if (v === null) continue;
          low = Math.min(low, v);
          high = Math.max(high, v);
        }
      }
      if (low > high) return;  // no values
      const [min, max] = ranges[i] ?? [NaN, NaN];
      if (!(min <= low && high <= max)) problems.push(`"${plot.title}": ${low} to ${high} outside ${min} to ${max}`);
      if (low === high) {
        flat++;
        // A flat series gets a little room around it, not uPlot's 0 to 100 for zeros.
        if (!(max - min <= Math.max(2, 4 * Math.abs(low)))) {
          problems.push(`"${plot.title}": all ${low}, shown from ${min} to ${max}`);
        }
      }
    });
    return [problems.length === 0, `${ranges.length} charts, ${flat} flat` + (problems.length ? `; ${problems.join('; ')}` : '')];
  });

  if (options.expectScale) {
    await runCheck('drawing scale', async () => {
      const scale = await page.evaluate(() => window.wbmDrawingScale);
      const [min, max] = options.expectScale;
      return [typeof scale === 'number' && scale >= min && scale <= max, `${scale} (expected ${min} to ${max})`];
    });
  }

  await runCheck('the robot stays in view', async () => {
    // The camera frames the robot over the whole run: a walking robot does not leave it.
    const n = await page.evaluate(() => JSON.parse(document.getElementById('wbm-data').textContent).time.length);
    const out = [];
    for (const k of [0, Math.floor(n / 2), n - 1]) {
      const count = await page.evaluate((i) => window.wbmBodiesOutOfView(i), k);
      if (count > 0) out.push(`${count} body origins out of view at sample ${k}`);
    }
    return [out.length === 0, out.length ? out.join('; ') : 'every body origin in view at the first, middle and last sample'];
  });

  await runCheck('time slider changes the 3D view', async () => {
    const value = await page.evaluate(moveSlider, 'end');
    const s = await page.evaluate(viewPixels, { keep: false, compare: true });
    return [s.changed > 0, `slider at ${value}: ${s.changed} of ${s.width * s.height} pixels changed`];
  });

  if (options.screenshot) {
    await runCheck('screenshot', async () => {
      const value = await page.evaluate(moveSlider, 'middle');
      const out = resolve(options.screenshot);
      await page.screenshot({ path: out, fullPage: true });
      return [true, `${out} (slider at ${value})`];
    });
  }

  await runCheck('no console or page errors', async () => [
    pageErrors.length === 0,
    pageErrors.length ? pageErrors.join(' | ') : 'none',
  ]);
  await runCheck('no requests outside the report', async () => [
    foreignRequests.length === 0,
    foreignRequests.length ? foreignRequests.join(', ') : 'none',
  ]);
} finally {
  await browser.close();
}

const passed = results.filter(Boolean).length;
const failed = results.length - passed;
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
