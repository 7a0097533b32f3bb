#!/usr/bin/env node
// Validates every .glb under the given folders (or the given files) with the
// Khronos glTF validator, loading the images they reference from disk so that
// those are checked too. Exits 1 if any file has errors or none was found.
//
//   cd tests && npm install
//   node tests/tools/validate_gltf.mjs <folder-or-file>...
import { createHash } from 'node:crypto';
import { readdir, readFile, stat } from 'node:fs/promises';
import { availableParallelism } from 'node:os';
import path from 'node:path';
import { Worker, isMainThread, parentPort, workerData } from 'node:worker_threads';

import { validateBytes } from 'gltf-validator';

const kShownErrors = 3;
const kSeverityError = 0;
const kGlbMagic = 0x46546c67; // 'glTF'
// The validator takes about 10 ms a tile on one core, and a test run leaves
// thousands of distinct files: they are split among this many worker threads.
const kMaxWorkers = 4;

// Files named on the command line are validated whatever their extension;
// inside folders only *.glb (so hidden temp files of atomic writes are skipped).
async function findGlbs(target, found) {
  const info = await stat(target);
  if (!info.isDirectory()) {
    found.push(target);
    return;
  }
  const entries = await readdir(target, { withFileTypes: true });
  entries.sort((a, b) => a.name.localeCompare(b.name));
  for (const entry of entries) {
    const full = path.join(target, entry.name);
    if (entry.isDirectory()) {
      await findGlbs(full, found);
    } else if (entry.isFile() && entry.name.toLowerCase().endsWith('.glb')) {
      found.push(full);
    }
  }
}

// Loads a URI the asset references (the normal map), relative to the .glb.
function resourceLoader(file) {
  return async (uri) => {
    const resolved = path.resolve(path.dirname(file), decodeURIComponent(uri));
    try {
      return new Uint8Array(await readFile(resolved));
    } catch (error) {
      throw `cannot read '${resolved}': ${error.message}`;
    }
  };
}

// The URIs of the files a GLB's JSON chunk references (its normal map);
// none when the JSON cannot be read (the validator reports that).
function referencedUris(bytes) {
  try {
    if (bytes.length < 20 || bytes.readUInt32LE(0) !== kGlbMagic) return [];
    const json = JSON.parse(bytes.subarray(20, 20 + bytes.readUInt32LE(12)).toString('utf8'));
    return [...(json.images ?? []), ...(json.buffers ?? [])]
      .map((entry) => entry.uri)
      .filter((uri) => typeof uri === 'string' && !uri.startsWith('data:'));
  } catch {
    return [];
  }
}

// A digest of the file and of every file it references: the tests write the
// same tile many times (resumed, sharded, compared runs), and equal inputs
// get equal reports. Null when a referenced file cannot be read, so that the
// validator reports it.
async function contentKey(file, bytes) {
  const hash = createHash('sha256').update(bytes);
  for (const uri of referencedUris(bytes)) {
    try {
      hash.update(uri).update(await readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))));
    } catch {
      return null;
    }
  }
  return hash.digest('hex');
}

// { errors, warnings, messages } of one file; a file the validator cannot
// even parse counts as one error.
async function validateFile(file, bytes) {
  try {
    const report = await validateBytes(new Uint8Array(bytes), {
      uri: path.basename(file),
      maxIssues: 0,
      writeTimestamp: false,
      externalResourceFunction: resourceLoader(file),
    });
    const messages = report.issues.messages
      .filter((m) => m.severity === kSeverityError)
      .map((m) => `${m.code}${m.pointer ? ` at ${m.pointer}` : ''}: ${m.message}`);
    return { errors: report.issues.numErrors, warnings: report.issues.numWarnings, messages };
  } catch (error) {
    return { errors: 1, warnings: 0, messages: [String(error.message ?? error)] };
  }
}

// Validates the files whose paths it is given, in a worker thread, and posts
// back their results in the same order.
async function validateInWorker(files) {
  const results = [];
  for (const file of files) {
    try {
      results.push(await validateFile(file, await readFile(file)));
    } catch (error) {
      results.push({ errors: 1, warnings: 0, messages: [`cannot read: ${error.message}`] });
    }
  }
  parentPort.postMessage(results);
}

// The results of the given files, validated by up to kMaxWorkers threads in
// interleaved shares (neighbouring files are alike in size).
async function validateAll(files) {
  const count = Math.max(1, Math.min(kMaxWorkers, availableParallelism(), files.length));
  const shares = Array.from({ length: count }, (_, w) => files.filter((_, i) => i % count === w));
  const answers = await Promise.all(shares.map((share) => new Promise((resolve, reject) => {
    const worker = new Worker(new URL(import.meta.url), { workerData: share });
    worker.once('message', resolve);
    worker.once('error', reject);
  })));
  return files.map((_, i) => answers[i % count][Math.floor(i / count)]);
}

async function main(targets) {
  const files = [];
  let errors = 0;
  for (const target of targets) {
    try {
      await findGlbs(target, files);
    } catch (error) {
      console.log(`${target}: cannot read: ${error.message}`);
      errors += 1;
    }
  }
  // Equal files (and references) are validated once: the first of each key.
  const keys = [];
  const distinct = new Map();
  for (const file of files) {
    let key = null;
    try {
      key = await contentKey(file, await readFile(file));
    } catch {
      // Unreadable: validated on its own, where the read fails again and is reported.
    }
    keys.push(key);
    if (key === null || !distinct.has(key)) distinct.set(key ?? file, file);
  }
  const toValidate = [...distinct.values()];
  const results = await validateAll(toValidate);
  const reports = new Map(toValidate.map((file, i) => [file, results[i]]));
  files.forEach((file, i) => {
    const result = reports.get(distinct.get(keys[i] ?? file));
    errors += result.errors;
    const shown = result.messages.slice(0, kShownErrors).map((m) => `; ${m}`).join('');
    console.log(`${file}: ${result.errors} errors, ${result.warnings} warnings${shown}`);
  });
  console.log(`glTF validator: ${files.length} files, ${errors} errors`);
  if (targets.length === 0) console.log('usage: node validate_gltf.mjs <folder-or-file>...');
  return files.length > 0 && errors === 0 ? 0 : 1;
}

if (isMainThread) {
  process.exitCode = await main(process.argv.slice(2));
} else {
  await validateInWorker(workerData);
}
