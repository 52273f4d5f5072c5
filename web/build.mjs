// Builds dist/report_template.html: one self-contained HTML file with three.js
// (+ OrbitControls), uPlot and the viewer inlined. Run `npm ci` first.
//
// The C++ report writer replaces the placeholder below (exactly once) with the
// JSON data, every `<` written as `\u003c`.

import { build } from 'esbuild';
import { mkdir, readFile, writeFile } from 'node:fs/promises';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const PLACEHOLDER = '__WBM_REPORT_DATA__';
const DATA_BLOCK = `<script type="application/json" id="wbm-data">${PLACEHOLDER}</script>`;

const root = dirname(fileURLToPath(import.meta.url));
const fromRoot = (...parts) => join(root, ...parts);

function fail(message) {
  console.error(`build.mjs: ERROR: ${message}`);
  process.exit(1);
}

function count(haystack, needle) {
  return haystack.split(needle).length - 1;
}

// Text inlined into <script> or <style> must not be able to end the element
// early or switch the HTML parser into its comment-like script states.
function checkInlinable(name, text, kind) {
  const lower = text.toLowerCase();
  const forbidden = ['</script', '<!--', PLACEHOLDER];
  if (kind === 'css') forbidden.push('</style');
  for (const needle of forbidden) {
    const at = lower.indexOf(needle.toLowerCase());
    if (at >= 0) {
      fail(`${name} contains "${needle}" at offset ${at}; it cannot be inlined safely`);
    }
  }
}

async function bundleThree() {
  const result = await build({
    entryPoints: [fromRoot('src', 'three-entry.js')],
    bundle: true,
    minify: true,
    format: 'iife',
    globalName: 'THREE',
    target: 'es2020',
    write: false,
    logLevel: 'warning',
  });
  return result.outputFiles[0].text;
}

const started = performance.now();

const [template, threeJs, uplotJs, uplotCss, reportJs, reportCss] = await Promise.all([
  readFile(fromRoot('src', 'template.html'), 'utf8'),
  bundleThree(),
  readFile(fromRoot('node_modules', 'uplot', 'dist', 'uPlot.iife.min.js'), 'utf8'),
  readFile(fromRoot('node_modules', 'uplot', 'dist', 'uPlot.min.css'), 'utf8'),
  readFile(fromRoot('src', 'report.js'), 'utf8'),
  readFile(fromRoot('src', 'report.css'), 'utf8'),
]);

const pieces = [
  { marker: '@@UPLOT_CSS@@', name: 'uplot/dist/uPlot.min.css', text: uplotCss, kind: 'css' },
  { marker: '@@REPORT_CSS@@', name: 'src/report.css', text: reportCss, kind: 'css' },
  { marker: '@@THREE_JS@@', name: 'three.js IIFE bundle', text: threeJs, kind: 'js' },
  { marker: '@@UPLOT_JS@@', name: 'uplot/dist/uPlot.iife.min.js', text: uplotJs, kind: 'js' },
  { marker: '@@REPORT_JS@@', name: 'src/report.js', text: reportJs, kind: 'js' },
];

if (count(template, DATA_BLOCK) !== 1) {
  fail(`src/template.html must contain ${DATA_BLOCK} exactly once`);
}

let html = template;
for (const piece of pieces) {
  checkInlinable(piece.name, piece.text, piece.kind);
  const n = count(html, piece.marker);
  if (n !== 1) fail(`src/template.html must contain ${piece.marker} exactly once (found ${n})`);
  html = html.split(piece.marker).join(piece.text);
}

const leftover = html.match(/@@[A-Z_]+@@/);
if (leftover) fail(`unreplaced marker ${leftover[0]} in the template`);
if (count(html, PLACEHOLDER) !== 1) fail(`${PLACEHOLDER} must appear exactly once in the output`);
if (count(html, DATA_BLOCK) !== 1) fail(`${DATA_BLOCK} must appear exactly once in the output`);

const outDir = fromRoot('dist');
const outFile = join(outDir, 'report_template.html');
await mkdir(outDir, { recursive: true });
await writeFile(outFile, html);

const kib = (n) => `${(Buffer.byteLength(n) / 1024).toFixed(1)} KiB`;
for (const piece of pieces) console.log(`  ${piece.name}: ${kib(piece.text)}`);
console.log(`wrote ${outFile} (${kib(html)}) in ${((performance.now() - started) / 1000).toFixed(2)} s`);
