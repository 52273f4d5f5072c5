// Writes a sample report by filling dist/report_template.html the way the C++
// report writer does: the JSON text, with every `<` written as `\u003c`,
// replaces the placeholder (which must occur exactly once).
//
//   node test/make_sample.mjs [--large | --minimal] [--out FILE]
//
// Default output: dist/sample_report.html (dist/sample_large_report.html,
// dist/sample_minimal_report.html for the variants).

import { readFile, writeFile } from 'node:fs/promises';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { makeSampleData } from './sample_data.mjs';

const PLACEHOLDER = '__WBM_REPORT_DATA__';
const root = join(dirname(fileURLToPath(import.meta.url)), '..');

const args = process.argv.slice(2);
let variant = 'default';
let out = null;
for (let i = 0; i < args.length; i++) {
  if (args[i] === '--large') variant = 'large';
  else if (args[i] === '--minimal') variant = 'minimal';
  else if (args[i] === '--out') out = resolve(args[++i]);
  else {
    console.error(`make_sample.mjs: unknown argument ${args[i]}`);
    process.exit(2);
  }
}
out ??= join(root, 'dist', variant === 'default' ? 'sample_report.html' : `sample_${variant}_report.html`);

const template = await readFile(join(root, 'dist', 'report_template.html'), 'utf8');
const parts = template.split(PLACEHOLDER);
if (parts.length !== 2) {
  console.error(`make_sample.mjs: the template must contain ${PLACEHOLDER} exactly once`);
  process.exit(1);
}

const json = JSON.stringify(makeSampleData({ variant })).replace(/</g, '\\u003c');
await writeFile(out, parts[0] + json + parts[1]);
console.log(`wrote ${out} (${(json.length / 1024).toFixed(1)} KiB of data)`);
