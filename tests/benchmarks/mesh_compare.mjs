// Martini (@mapbox/martini) and Delatin on the heights mesh_compare wrote, at
// the same bounds as its grid and adaptive meshes, and the comparison table.
//
//   node tests/benchmarks/mesh_compare.mjs OUT_DIR/results.json [--repeats N] [--json merged.json]
//
// Each window is a 257 x 257 float32 grid: the tile's 256 x 256 pixels plus
// the window's next column and row (Martini needs 2^k + 1 a side). Both
// meshers put vertices on those samples and bound the vertical error there.
// Prints one markdown table per DEM: medians over its windows.
import { readFileSync, writeFileSync } from 'node:fs';
import { performance } from 'node:perf_hooks';

import Martini from '@mapbox/martini';
import Delatin from 'delatin';

// A case's timed repeats stop early once they have taken this long.
const TIME_BUDGET_MS = 500;

function usage() {
  console.error('usage: node mesh_compare.mjs RESULTS.json [--repeats N] [--json MERGED.json]');
  process.exit(2);
}

const args = process.argv.slice(2);
let resultsPath = null;
let repeats = null;
let mergedPath = null;
for (let k = 0; k < args.length; ++k) {
  if (args[k] === '--repeats' && k + 1 < args.length) repeats = Math.max(1, parseInt(args[++k], 10));
  else if (args[k] === '--json' && k + 1 < args.length) mergedPath = args[++k];
  else if (!resultsPath && !args[k].startsWith('--')) resultsPath = args[k];
  else usage();
}
if (!resultsPath) usage();

const report = JSON.parse(readFileSync(resultsPath, 'utf8'));
repeats ??= report.repeats;
const size = report.martini_grid;

function readHeights(path) {
  const bytes = readFileSync(path);
  if (bytes.length !== size * size * 4) throw new Error(`${path}: expected ${size} x ${size} float32 heights`);
  // A copy: the Buffer's offset in its pool need not be a multiple of 4.
  return new Float32Array(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.length));
}

function median(values) {
  const sorted = [...values].sort((a, b) => a - b);
  const n = sorted.length;
  return n % 2 ? sorted[(n - 1) / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
}

// Milliseconds per call: the median of up to `repeats` timed calls after an
// untimed warm-up call, which also gives the result.
function timed(build) {
  const result = build();
  const times = [];
  let spent = 0;
  for (let k = 0; k < repeats && (k === 0 || spent < TIME_BUDGET_MS); ++k) {
    const start = performance.now();
    build();
    const t = performance.now() - start;
    times.push(t);
    spent += t;
  }
  return { result, ms: median(times) };
}

// The largest vertical distance between a sample of the grid and the mesh
// over it: each triangle's samples, interpolated linearly. Samples on a
// shared edge are measured in both triangles (the same value).
function maxVerticalError(coords, triangles, heights) {
  let worst = 0;
  for (let t = 0; t < triangles.length; t += 3) {
    const a = triangles[t], b = triangles[t + 1], c = triangles[t + 2];
    const ax = coords[2 * a], ay = coords[2 * a + 1];
    const bx = coords[2 * b], by = coords[2 * b + 1];
    const cx = coords[2 * c], cy = coords[2 * c + 1];
    const ha = heights[ay * size + ax], hb = heights[by * size + bx], hc = heights[cy * size + cx];
    const area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
    if (area === 0) continue;
    const eps = 1e-9 * Math.abs(area);
    for (let y = Math.min(ay, by, cy); y <= Math.max(ay, by, cy); ++y) {
      for (let x = Math.min(ax, bx, cx); x <= Math.max(ax, bx, cx); ++x) {
        const wa = ((bx - x) * (cy - y) - (by - y) * (cx - x)) / area;
        const wb = ((cx - x) * (ay - y) - (cy - y) * (ax - x)) / area;
        const wc = 1 - wa - wb;
        if (wa < -eps || wb < -eps || wc < -eps) continue;
        worst = Math.max(worst, Math.abs(wa * ha + wb * hb + wc * hc - heights[y * size + x]));
      }
    }
  }
  return worst;
}

const martini = new Martini(size);
// One untimed pass over the first window at every bound first, so that the
// first windows are timed with the code already compiled too.
{
  const heights = readHeights(report.dems[0].windows[0].heights);
  for (const level of report.dems[0].levels) {
    martini.createTile(heights).getMesh(level.bounds[0]);
    new Delatin(heights, size, size).run(level.bounds[0]);
  }
}
for (const dem of report.dems) {
  console.error(`Martini and Delatin on ${dem.name}`);
  for (const level of dem.levels) {
    level.martini = { triangles: [], max_error_m: [], ms: [] };
    level.delatin = { triangles: [], max_error_m: [], ms: [] };
  }
  dem.martini_create_tile_ms = [];
  dem.windows.forEach((window, w) => {
    const heights = readHeights(window.heights);
    const { result: tile, ms: createMs } = timed(() => martini.createTile(heights));
    dem.martini_create_tile_ms.push(createMs);
    for (const level of dem.levels) {
      const bound = level.bounds[w];
      const m = timed(() => tile.getMesh(bound));
      level.martini.triangles.push(m.result.triangles.length / 3);
      level.martini.max_error_m.push(maxVerticalError(m.result.vertices, m.result.triangles, heights));
      level.martini.ms.push(m.ms);
      const d = timed(() => {
        const tin = new Delatin(heights, size, size);
        tin.run(bound);
        return tin;
      });
      level.delatin.triangles.push(d.result.triangles.length / 3);
      level.delatin.max_error_m.push(maxVerticalError(d.result.coords, d.result.triangles, heights));
      level.delatin.ms.push(d.ms);
    }
  });
}
if (mergedPath) writeFileSync(mergedPath, JSON.stringify(report, null, 1) + '\n');

// The table.
const int = (v) => (v === null ? '—' : Math.round(v).toLocaleString('en-US'));
const metres = (v) => (v >= 10 ? v.toFixed(0) : v.toPrecision(2));
const millis = (v) => (v >= 10 ? v.toFixed(0) : v >= 1 ? v.toFixed(1) : v.toFixed(2));

// The median of per-window values where a missing one (no grid meets the
// bound) counts as more than any.
function medianOrNone(values) {
  const m = median(values.map((v) => (v === null ? Infinity : v)));
  return Number.isFinite(m) ? m : null;
}

const lines = [];
lines.push(`Tiles of ${report.tile_size} x ${report.tile_size} samples; medians over 9 windows per DEM; ` +
  `ms per tile: median of up to ${repeats} warm runs per window.`);
lines.push('Bounds: ours is the 3-D distance from each sample to the mesh at the same UV (>= vertical); ' +
  "Martini's and Delatin's is vertical, in height units. In this flat metric frame the two coincide.");
lines.push(`Martini and Delatin mesh ${size} x ${size} samples (the tile's plus one more column and row); ` +
  "grid and adaptive vertices span the tile's texel square (edge vertices between samples).");
for (const dem of report.dems) {
  const pixel = dem.pixel_m[0] === dem.pixel_m[1] ? `${dem.pixel_m[0]} m` : `${dem.pixel_m.join(' x ')} m`;
  lines.push('');
  lines.push(`#### ${dem.name}: ${dem.description}; ${dem.size.join(' x ')} pixels of ${pixel}`);
  lines.push('');
  lines.push('| max error (m) | grid triangles | adaptive | Martini | Delatin | ' +
    'achieved (m): adaptive / Martini / Delatin | ms: adaptive | ms: Martini createTile + getMesh | ms: Delatin |');
  lines.push('| --- | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: |');
  const createMs = median(dem.martini_create_tile_ms);
  for (const level of dem.levels) {
    const bound = median(level.bounds);
    const label = level.kind === 'grid'
      ? `${metres(bound)} (grid ${level.grid}², its error)`
      : `${metres(bound)}`;
    const gridVertices = medianOrNone(level.grid_vertices);
    const grid = level.kind === 'grid'
      ? int(median(level.grid_triangles))
      : gridVertices === null ? 'none ≤ 257²' : `${int(medianOrNone(level.grid_triangles))} (${gridVertices}²)`;
    const achieved = [level.adaptive, level.martini, level.delatin]
      .map((mesher) => metres(median(mesher.max_error_m))).join(' / ');
    lines.push(`| ${label} | ${grid} | ${int(median(level.adaptive.triangles))} | ` +
      `${int(median(level.martini.triangles))} | ${int(median(level.delatin.triangles))} | ${achieved} | ` +
      `${millis(median(level.adaptive.ms))} | ${millis(createMs)} + ${millis(median(level.martini.ms))} | ` +
      `${millis(median(level.delatin.ms))} |`);
  }
}
lines.push('');
lines.push('Crack-free between neighbouring tiles: grid and adaptive yes (the adaptive mesh picks its edge ' +
  "vertices from the shared edge's profile alone); Martini and Delatin no (a tile's edge vertices depend on its " +
  'inside, so neighbours differ; they need skirts).');
lines.push('grid triangles on a fixed bound: the coarsest grid of 2^k + 1 vertices a side that meets it (median ' +
  'over windows); none ≤ 257²: not even a vertex per texel corner does (corners lie between samples).');
console.log(lines.join('\n'));
