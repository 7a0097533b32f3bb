#!/usr/bin/env node
// Checks validate_gltf.mjs itself: that it reports each file's own result
// when the files are shared among worker threads and equal files are
// validated once, and that it fails on broken files and on none.
//
//   node tests/tools/validate_gltf_test.mjs <scratch folder>
import { spawnSync } from 'node:child_process';
import { mkdirSync, rmSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const kValidator = path.join(path.dirname(fileURLToPath(import.meta.url)), 'validate_gltf.mjs');

// A GLB of one JSON chunk (padded with spaces to 4 bytes, as the format asks).
function glb(json) {
  let text = JSON.stringify(json);
  while (text.length % 4 !== 0) text += ' ';
  const chunk = Buffer.from(text, 'utf8');
  const header = Buffer.alloc(20);
  header.writeUInt32LE(0x46546c67, 0);  // 'glTF'
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(20 + chunk.length, 8);
  header.writeUInt32LE(chunk.length, 12);
  header.writeUInt32LE(0x4e4f534a, 16);  // 'JSON'
  return Buffer.concat([header, chunk]);
}

const valid = glb({ asset: { version: '2.0' } });
const validOther = glb({ asset: { version: '2.0', generator: 'validate_gltf_test' } });
const missingImage = glb({ asset: { version: '2.0' }, images: [{ uri: 'absent.png' }] });
const truncated = valid.subarray(0, 10);

const failures = [];
function check(condition, message) {
  if (!condition) failures.push(message);
}

function validate(targets) {
  const run = spawnSync(process.execPath, [kValidator, ...targets], { encoding: 'utf8' });
  const errorsOf = new Map();
  for (const line of run.stdout.split('\n')) {
    const match = /^(.*\.glb): (\d+) errors/.exec(line);
    if (match) errorsOf.set(path.basename(match[1]), Number(match[2]));
  }
  return { status: run.status, errorsOf, output: run.stdout + run.stderr };
}

const scratch = process.argv[2];
if (!scratch) {
  console.log('usage: node validate_gltf_test.mjs <scratch folder>');
  process.exit(2);
}
rmSync(scratch, { recursive: true, force: true });

// Eleven files, more than the workers, good and bad interleaved, with
// repeats: each must get its own count.
const mixed = path.join(scratch, 'mixed');
mkdirSync(mixed, { recursive: true });
const expected = new Map();
const kinds = [[valid, 0], [truncated, 1], [validOther, 0], [missingImage, 1]];
for (let i = 0; i < 11; ++i) {
  const [bytes, errors] = kinds[(i * 3) % kinds.length];
  const name = `${String(i).padStart(2, '0')}.glb`;
  writeFileSync(path.join(mixed, name), bytes);
  expected.set(name, errors);
}
writeFileSync(path.join(mixed, '.hidden.glb.tmp-1'), truncated);  // not a .glb: skipped
const all = validate([mixed]);
check(all.status === 1, `a folder with broken files: exit status ${all.status}, expected 1`);
check(all.errorsOf.size === expected.size, `reported ${all.errorsOf.size} files, expected ${expected.size}`);
for (const [name, errors] of expected) {
  check(all.errorsOf.get(name) === errors, `${name}: ${all.errorsOf.get(name)} errors reported, expected ${errors}`);
}
const total = [...expected.values()].reduce((a, b) => a + b, 0);
check(all.output.includes(`glTF validator: ${expected.size} files, ${total} errors`),
  `the summary line does not say ${expected.size} files, ${total} errors`);

// Good files alone pass; an empty folder and a missing path fail.
const good = path.join(scratch, 'good');
mkdirSync(good, { recursive: true });
for (let i = 0; i < 5; ++i) writeFileSync(path.join(good, `${i}.glb`), i % 2 ? valid : validOther);
const clean = validate([good]);
check(clean.status === 0, `five valid files: exit status ${clean.status}, expected 0`);
const empty = path.join(scratch, 'empty');
mkdirSync(empty, { recursive: true });
check(validate([empty]).status === 1, 'a folder without any .glb passed');
check(validate([path.join(scratch, 'absent')]).status === 1, 'a path that does not exist passed');

if (failures.length > 0) {
  for (const failure of failures) console.log(`FAIL: ${failure}`);
  console.log(all.output);
  process.exit(1);
}
console.log('validate_gltf.mjs: every file reported with its own result');
