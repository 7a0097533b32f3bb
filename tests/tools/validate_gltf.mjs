#!/usr/bin/env node
// Validates every .glb under the given folders (or the given files) with the
// Khronos glTF validator, loading the images they reference from disk so that
// those are checked too. Exits 1 if any file has errors or none was found.
//
//   cd tests && npm install
//   node tests/tools/validate_gltf.mjs <folder-or-file>...
import { readdir, readFile, stat } from 'node:fs/promises';
import path from 'node:path';

import { validateBytes } from 'gltf-validator';

const kShownErrors = 3;
const kSeverityError = 0;

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

// { errors, warnings, messages } of one file; a file the validator cannot
// even parse counts as one error.
async function validateFile(file) {
  try {
    const report = await validateBytes(new Uint8Array(await readFile(file)), {
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
  for (const file of files) {
    const result = await validateFile(file);
    errors += result.errors;
    const shown = result.messages.slice(0, kShownErrors).map((m) => `; ${m}`).join('');
    console.log(`${file}: ${result.errors} errors, ${result.warnings} warnings${shown}`);
  }
  console.log(`glTF validator: ${files.length} files, ${errors} errors`);
  if (targets.length === 0) console.log('usage: node validate_gltf.mjs <folder-or-file>...');
  return files.length > 0 && errors === 0 ? 0 : 1;
}

process.exitCode = await main(process.argv.slice(2));
