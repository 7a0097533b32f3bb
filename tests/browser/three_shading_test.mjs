#!/usr/bin/env node
// Does a real renderer lit with terrabake's normal map show the high-res
// normals? three.js in headless Chromium, one tile of the sample DEM.
//
//   node tests/browser/three_shading_test.mjs <terrabake executable> <output folder>
//
// 1. Tiles one zoom-12 tile of the sample DEM at 16 bits with its high-res mesh
//    into <out>/tiles/sample16/ (the default low-poly mesh: adaptive, one
//    texel), and again with the regular grid (low_poly.grid 17, 512 triangles)
//    and with an adaptive mesh of 486 to 512 triangles (--max-error found by
//    bisection; one bake as a rule) into sample16_grid/ and sample16_adaptive<k>/.
// 2. Starts `terrabake serve` on it (which also serves three.js from the
//    viewer's node_modules under /vendor/three/) and opens a test page on the
//    same origin (three_shading_page.mjs, handed to Chromium by the test):
//    nothing comes from the network.
// 3. The page loads the tile's .glb and .hires.glb with GLTFLoader (so the
//    normal map is applied by MeshStandardMaterial, as GLTFLoader sets it up)
//    and renders each with an orthographic camera looking straight down (no
//    parallax: a pixel is the same ground point on both meshes) and one white
//    directional light of intensity pi (no ambient light, no environment;
//    white base colour, roughness 1, metalness 0: nearly Lambert), into a float
//    render target (linear, no tone mapping), one sample a pixel, three pixels
//    a texel:
//      normalmap       the .glb as loaded, with its normal map
//      highres         the .hires.glb as loaded (one vertex a texel, no normal map)
//      lowpoly         the .glb without its normal map (the control)
//      greenFlipped    the .glb with normalScale.y = -1 (a control the bounds must reject)
//      perVertexJs     the .glb with a normal map made on the page from the two
//                      meshes for three's frame (CONTRACT.md §4), 8 bits
//      perVertexFloat  the same map, not rounded
//      perPixelJs      a map made the same way for the frame the bake inverted
//                      before (bitangent w * cross(N, T) from the interpolated N
//                      and T), 8 bits
//      lambert         the .hires.glb with MeshLambertMaterial
//      lowpolyFlat     the .glb without its normal map, flat shaded (the geometry alone)
//      lowpolyHeight, highresHeight
//                      unlit, the height in metres (up the tile's frame) in red
//      grid_*, adaptive_*
//                      the grid and the adaptive mesh of about as many
//                      triangles, each with its own normal map (normalmap),
//                      without it (lowpoly), flat shaded (flat) and heights (height)
//    and computes `expected`, max(0, n . sun) at every pixel with n the
//    .hires.glb's normals interpolated as the GPU does.
// 4. Compares the red channel (0..255 = linear 0..1) over the pixels both
//    meshes cover, by mean absolute difference and 99th percentile:
//    normalmap against highres within bounds, and many times closer than
//    lowpoly; where the two frames' maps differ, normalmap clearly closer than
//    perPixelJs; perVertexJs equal to the PNG; lambert equal to expected (the
//    light is where the test thinks). The grid and the adaptive mesh of as
//    many triangles: both within the normal map's bounds with their maps;
//    without them the adaptive mesh closer (shading, flat shading, heights,
//    and the achieved error of asset.extras.terrabake.max_error_m); a table.
// 5. Keeps the renders (8-bit, linear x 255, blue where empty) and difference
//    images (|difference| x 8) in <out>/, and stops the server with SIGTERM.
//    TERRABAKE_SHADING_DUMP=1 also writes each render as raw float32
//    (render_<name>.f32, rows from the top, NaN where empty).
//
// Exit code: 0 passed, 1 failed, 77 skipped (no Chromium or no playwright-core).
import { existsSync } from 'node:fs';
import { readFile, writeFile } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { createBrowserTest, encodePngRgb, kRepo } from './browser_test_support.mjs';

const kHere = path.dirname(fileURLToPath(import.meta.url));

// Limits. The whole test takes 15 to 40 s on the 2-core development machine.
const kTileTimeoutMs = 120_000;
const kPageTimeoutMs = 60_000;
const kRenderTimeoutMs = 180_000;
const kWatchdogMs = 420_000;

// The tile: 12/2161/1448 holds the centre of the sample DEM (which covers it
// completely); it is rough, Alpine terrain. Baked alone with a box around its
// centre.
const kTile = { z: 12, x: 2161, y: 1448 };
const kLayer = 'sample16';
// Three canvas pixels a texel (tile_size 256): an odd number, so texel centres,
// where the high-res vertices are, fall on pixel centres.
const kCanvas = 768;
// Sun from the north-west (both horizontal components non-zero, so a flipped
// red or green channel changes the picture), 35 degrees high as in the viewer:
// flat ground shades 0.57, and slopes show. Intensity pi: a white Lambert
// surface facing the sun shades 1.
const kSun = { azimuthDeg: 315, elevationDeg: 35, intensity: Math.PI };

// Thresholds, on the 0..255 scale of the linear red channel (a 1 degree
// error in a normal moves the shade by at most 4.5). Measured on the 2-core
// development machine (SwiftShader), over the 586,756 pixels both meshes cover,
// with the default mesh (adaptive, one texel: 1,626 triangles, within 26.3 m):
//   normalmap vs highres         mean  0.71, p99  4.8
//   the same map, not rounded    mean  0.58, p99  4.8
//   lowpoly vs highres           mean 19.8,  p99 74    (28 times the normal-mapped mean)
//   green flipped vs highres     mean 31.3,  p99 117
//   lambert vs expected          mean  0.08, max  1.6
//   where the two frames' maps differ (123 texels): normalmap mean 1.06,
//   the per-pixel frame's map 2.76
//
// Normal-mapped against high-res. Both interpolate the same texel-centre
// normals, but the texture bilinearly (tangent-space values, then the frame)
// and the high-res mesh over its triangles, so between texel centres they part
// on rough terrain: that sets the p99. The map reaches WebGL rounded to 8 bits
// (the browser decodes the 16-bit PNG to 8), which adds about 0.13 to the mean.
// The bounds leave room for another GPU's coarser texture filtering: 1.4x the
// measured mean, 1.25x the measured p99 (set on the 512-triangle grid, which
// measures 0.68 and 4.6). A flipped green channel (below) is far outside both.
const kMaxMeanNormalMap = 1.0;
const kMaxP99NormalMap = 6;
// The normal map must bring the low-poly mesh at least this much closer to the
// high-res one than it is bare, by the mean (measured 28; 41 on the grid).
const kMinImprovement = 20;
// Without its normal map the low-poly mesh must differ clearly (measured
// 19.8), or the comparison says nothing.
const kMinMeanBare = 10;
// On the pixels of the texels where a map for the per-pixel frame (bitangent
// w * cross(N, T) per pixel) differs from one for three's frame by more than
// one 8-bit step, the PNG must be at least this much closer to the high-res
// render than the per-pixel frame's map (measured 2.6x; 3.6x on the grid), so a
// bake that switched to that frame fails. There must be enough such texels for
// a mean to mean something (measured 123; 229 on the grid: fixed by the tile's
// meshes).
const kMinFrameImprovement = 2;
const kMinDifferingTexels = 50;
// The lambert render against max(0, n_high . sun) computed on the page from
// the .hires.glb's normals, interpolated as the GPU does: the light is where
// and as strong as the test thinks. Only float32 rounding in the GPU's
// interpolation.
const kMaxMeanLambert = 0.25;
const kMaxLambert = 3;
// The shading must be lit and not saturated: mean of the high-res render
// (measured 105.6: rough terrain, much of it facing away from the sun).
const kMeanShadeRange = [60, 200];
// The two meshes must overlap on most of the canvas (measured 99.5 %: the
// high-res mesh starts half a texel in from the west and north edges).
const kMinCoverage = 0.95;
// The normal map made on the page for three's frame must be the PNG as the
// browser decoded it: texels more than one 8-bit step apart, of 65,536
// (measured 0).
const kMaxTexelsBeyondOneStep = 16;

// The adaptive mesh against the regular grid at the same triangle count: the
// tile baked again with low_poly.grid kGrid (512 triangles), and with an
// adaptive mesh of at most as many triangles and at least (1 -
// kTriangleTolerance) times as many, its --max-error found by bisection
// (geometric, within kMaxErrorBracketM) from kMaxErrorStartM, the bound that
// gave 502 triangles when the test was written (so one bake, as a rule).
// Measured (mean / p99 against highres; red channel 0..255, heights in m):
//                       triangles  max error  with map    without map   flat shaded   height
//   grid 17                   512    187.6 m  0.68 / 4.6  27.7 / 97.1   25.6 / 99.9   20.5 / 88.0
//   adaptive, 60 m            502     60.0 m  0.69 / 4.7  26.7 / 92.2   23.4 / 90.7   16.5 / 49.8
//   adaptive, 62.5 m          461     62.3 m  0.69 / 4.7  27.3 / 94.8   23.8 / 91.2   17.0 / 51.5
// Both, normal-mapped, must meet the normal map's bounds above. Without the
// map, the adaptive mesh must be the closer, by every measure: it follows the
// terrain better. The margins are small in the shading (the shade of a bare
// mesh depends on slopes shorter than any of its triangles, which neither
// mesh has) and large in the height and the achieved error (extras), so
// those get factors: measured 0.57 and 0.32.
const kGrid = 17;
const kTriangleTolerance = 0.05;
const kMaxErrorStartM = 60;
const kMaxErrorBracketM = [1, 400];
const kMaxBisectionBakes = 8;
const kMaxHeightP99Ratio = 0.75;
const kMaxAchievedErrorRatio = 0.5;

const t = createBrowserTest('three_shading_test', { watchdogMs: kWatchdogMs });
const { fail, log } = t;

function tileCentreLonLat({ z, x, y }) {
  const n = 2 ** z;
  const lon = ((x + 0.5) / n) * 360 - 180;
  const lat = (Math.atan(Math.sinh(Math.PI * (1 - (2 * (y + 0.5)) / n))) * 180) / Math.PI;
  return [lon, lat];
}

// A .glb's triangle count (its one primitive's indices) and
// asset.extras.terrabake.max_error_m.
async function glbMesh(file) {
  const bytes = await readFile(file);
  const json = JSON.parse(bytes.subarray(20, 20 + bytes.readUInt32LE(12)).toString('utf8'));
  const primitive = json.meshes[0].primitives[0];
  return { triangles: json.accessors[primitive.indices].count / 3, maxErrorM: json.asset?.extras?.terrabake?.max_error_m };
}

function fromBase64(text) {
  const bytes = Buffer.from(text, 'base64');
  return new Float32Array(bytes.buffer, bytes.byteOffset, bytes.byteLength / 4);
}

// |a - b| x scale over the mask: mean, 99th percentile, max.
function compare(a, b, mask, scale = 255) {
  const d = [];
  for (let p = 0; p < mask.length; ++p) if (mask[p]) d.push(scale * Math.abs(a[p] - b[p]));
  if (d.length === 0) return { mean: NaN, p99: NaN, max: NaN, n: 0 };
  const sorted = Float64Array.from(d).sort();
  const mean = d.reduce((s, v) => s + v, 0) / d.length;
  return { mean, p99: sorted[Math.floor(0.99 * (sorted.length - 1))], max: sorted[sorted.length - 1], n: d.length };
}

// A render as an 8-bit picture (linear value x 255), blue where it is empty.
function renderPng(width, height, values) {
  const rgb = Buffer.alloc(width * height * 3);
  for (let p = 0; p < values.length; ++p) {
    if (Number.isNaN(values[p])) {
      rgb.set([40, 70, 120], 3 * p);
    } else {
      rgb.fill(Math.max(0, Math.min(255, Math.round(255 * values[p]))), 3 * p, 3 * p + 3);
    }
  }
  return encodePngRgb(width, height, rgb);
}

// |a - b| x 255 x 8 as grey over the mask, black elsewhere.
function diffPng(width, height, a, b, mask) {
  const rgb = Buffer.alloc(width * height * 3);
  for (let p = 0; p < mask.length; ++p) {
    if (mask[p]) rgb.fill(Math.min(255, Math.round(8 * 255 * Math.abs(a[p] - b[p]))), 3 * p, 3 * p + 3);
  }
  return encodePngRgb(width, height, rgb);
}

async function main() {
  const { terrabake, out, tilesDir } = await t.setUp('three_shading_test.mjs');

  // 1. One tile.
  const [lon, lat] = tileCentreLonLat(kTile);
  const bbox = [lon - 0.001, lat - 0.001, lon + 0.001, lat + 0.001].map((v) => v.toFixed(6)).join(',');
  await t.tile(terrabake, ['--config', path.join(kRepo, 'config/sample.yaml'), '--zoom', String(kTile.z),
    '--bits', '16', '--high-res-mesh', 'true', '--bbox', bbox, '--out', tilesDir, '--layer', kLayer], kTileTimeoutMs);
  const tilePath = `${kLayer}/${kTile.z}/${kTile.x}/${kTile.y}`;
  for (const ext of ['.png', '.glb', '.hires.glb']) {
    if (!existsSync(path.join(tilesDir, tilePath + ext))) await t.abort(`terrabake tile wrote no ${tilePath}${ext}`);
  }

  // The same tile with the regular grid, and with an adaptive mesh of about
  // as many triangles: the bound found by bisection on --max-error, starting
  // from the one that gave it when the test was written.
  const tileId = `${kTile.z}/${kTile.x}/${kTile.y}`;
  const bakeLowPoly = async (layer, args) => {
    await t.tile(terrabake, ['--config', path.join(kRepo, 'config/sample.yaml'), '--zoom', String(kTile.z),
      '--bits', '16', '--bbox', bbox, '--out', tilesDir, '--layer', layer, ...args], kTileTimeoutMs);
    const glb = path.join(tilesDir, layer, `${tileId}.glb`);
    if (!existsSync(glb)) await t.abort(`terrabake tile wrote no ${layer}/${tileId}.glb`);
    return { layer, ...(await glbMesh(glb)) };
  };
  const meshes = { adaptive1: { layer: kLayer, ...(await glbMesh(path.join(tilesDir, `${tilePath}.glb`))) } };
  meshes.grid = await bakeLowPoly(`${kLayer}_grid`, ['--low-poly', 'grid', '--low-poly-grid', String(kGrid)]);
  {
    const target = meshes.grid.triangles;
    const near = (m) => m.triangles <= target && m.triangles >= (1 - kTriangleTolerance) * target;
    let [lo, hi] = kMaxErrorBracketM;  // triangles fall as the bound grows
    let bound = kMaxErrorStartM;
    let best = null;
    for (let trial = 0; trial < kMaxBisectionBakes; ++trial) {
      bound = Number(bound.toFixed(2));
      const m = { ...(await bakeLowPoly(`${kLayer}_adaptive${trial}`, ['--low-poly', 'adaptive', '--max-error', String(bound)])), bound };
      log(`adaptive, --max-error ${bound}: ${m.triangles} triangles`);
      if (!best || near(m) || Math.abs(m.triangles - target) < Math.abs(best.triangles - target)) best = m;
      if (near(m)) break;
      if (m.triangles > target) lo = bound; else hi = bound;
      bound = Math.sqrt(lo * hi);
    }
    meshes.adaptive = best;
    if (!near(best)) fail(`no --max-error within ${kMaxBisectionBakes} bakes gives ${(1 - kTriangleTolerance) * target} to ${target} triangles (closest ${best.triangles})`);
  }

  // 2. The server, and the test page on its origin.
  const server = await t.serve(terrabake, tilesDir);
  const context = await t.launchChromium({ viewport: { width: kCanvas, height: kCanvas } });
  const pageBase = `${server.url}three-shading-test/`;
  const pageModule = await readFile(path.join(kHere, 'three_shading_page.mjs'));
  const pageHtml = `<!doctype html>
<html><head><meta charset="utf-8"><link rel="icon" href="data:,">
<script type="importmap">
{ "imports": { "three": "/vendor/three/build/three.module.js", "three/addons/": "/vendor/three/examples/jsm/" } }
</script>
<script type="module" src="./page.mjs"></script>
</head><body style="margin:0"></body></html>`;
  await context.route(`${pageBase}*`, (route) => {
    const name = new URL(route.request().url()).pathname.split('/').pop();
    if (name === 'index.html') return route.fulfill({ contentType: 'text/html', body: pageHtml });
    if (name === 'page.mjs') return route.fulfill({ contentType: 'text/javascript', body: pageModule });
    return route.fulfill({ status: 404, body: '' });
  });

  // 3. The renders.
  const { page, ok } = await t.openPage(`${pageBase}index.html`, 'test page', { timeoutMs: kPageTimeoutMs });
  if (!ok) await t.abort('the test page did not load');
  const started = Date.now();
  let timer;
  const result = await Promise.race([
    page.evaluate((options) => window.terrabakeShading.render(options), {
      lowPolyUrl: `/${tilePath}.glb`, highResUrl: `/${tilePath}.hires.glb`, width: kCanvas, height: kCanvas,
      meshes: { grid: `/${meshes.grid.layer}/${tileId}.glb`, adaptive: `/${meshes.adaptive.layer}/${tileId}.glb` },
      sunAzimuthDeg: kSun.azimuthDeg, sunElevationDeg: kSun.elevationDeg, sunIntensity: kSun.intensity,
    }),
    new Promise((_, reject) => { timer = setTimeout(() => reject(new Error(`no renders within ${kRenderTimeoutMs / 1000} s`)), kRenderTimeoutMs); }),
  ]).finally(() => clearTimeout(timer));
  log(`loaded and rendered in ${((Date.now() - started) / 1000).toFixed(1)} s: ${JSON.stringify(result.info)}`);
  await t.closePage(page);
  await t.closeChromium();
  await t.stopServer(server);
  for (const problem of result.problems) fail(problem);
  if (!result.renders) return;

  // 4. The metric.
  const { width, height } = result;
  const r = Object.fromEntries(Object.entries(result.renders).map(([name, text]) => [name, fromBase64(text)]));
  for (const [name, values] of Object.entries(r)) {
    await writeFile(path.join(out, `render_${name}.png`), renderPng(width, height, values));
  }
  const mask = new Uint8Array(width * height);
  let covered = 0;
  for (let p = 0; p < mask.length; ++p) {
    if (Object.values(r).every((values) => !Number.isNaN(values[p]))) {
      mask[p] = 1;
      ++covered;
    }
  }
  const coverage = covered / mask.length;
  const nm = compare(r.normalmap, r.highres, mask);
  const bare = compare(r.lowpoly, r.highres, mask);
  const perVertex = compare(r.perVertexJs, r.highres, mask);
  const perPixel = compare(r.perPixelJs, r.highres, mask);
  const perVertexFloat = compare(r.perVertexFloat, r.highres, mask);
  const flipped = compare(r.greenFlipped, r.highres, mask);
  // The pixels of the texels where the two frames' maps differ.
  const framesMask = new Uint8Array(width * height);
  const pixelsPerTexel = width / result.size;
  for (const texel of result.differing) {
    const i = texel % result.size;
    const j = Math.floor(texel / result.size);
    for (let y = Math.floor(j * pixelsPerTexel); y < Math.floor((j + 1) * pixelsPerTexel); ++y) {
      for (let x = Math.floor(i * pixelsPerTexel); x < Math.floor((i + 1) * pixelsPerTexel); ++x) framesMask[y * width + x] = mask[y * width + x];
    }
  }
  const nmWhereFramesDiffer = compare(r.normalmap, r.highres, framesMask);
  const perPixelWhereFramesDiffer = compare(r.perPixelJs, r.highres, framesMask);
  const specular = compare(r.highres, r.lambert, mask);
  let meanShade = 0;
  for (let p = 0; p < mask.length; ++p) if (mask[p]) meanShade += 255 * r.highres[p];
  meanShade /= covered;

  const lambert = compare(r.lambert, r.expected, mask);
  const nmExpected = compare(r.normalmap, r.expected, mask);
  if (process.env.TERRABAKE_SHADING_DUMP) {
    for (const [name, values] of Object.entries(r)) await writeFile(path.join(out, `render_${name}.f32`), Buffer.from(values.buffer, values.byteOffset, values.byteLength));
  }

  for (const [name, a, b] of [['normalmap_highres', r.normalmap, r.highres], ['lowpoly_highres', r.lowpoly, r.highres],
    ['perpixel_highres', r.perPixelJs, r.highres]]) {
    await writeFile(path.join(out, `diff_${name}.png`), diffPng(width, height, a, b, mask));
  }

  // The three low-poly meshes against highres.
  const metrics = { adaptive1: { withMap: nm, withoutMap: bare, flat: compare(r.lowpolyFlat, r.highres, mask),
    height: compare(r.lowpolyHeight, r.highresHeight, mask, 1) } };
  for (const name of ['grid', 'adaptive']) {
    metrics[name] = { withMap: compare(r[`${name}_normalmap`], r.highres, mask), withoutMap: compare(r[`${name}_lowpoly`], r.highres, mask),
      flat: compare(r[`${name}_flat`], r.highres, mask), height: compare(r[`${name}_height`], r.highresHeight, mask, 1) };
  }

  console.log('');
  console.log(`  Tile ${kTile.z}/${kTile.x}/${kTile.y}, ${width} x ${height} pixels (${result.info.footprintM.map((m) => m.toFixed(0)).join(' x ')} m), ` +
    `sun azimuth ${kSun.azimuthDeg}, elevation ${kSun.elevationDeg}; ${covered} pixels both meshes cover (${(100 * coverage).toFixed(1)} %).`);
  console.log('  Red channel, linear, 0..255; mean shade of highres ' + meanShade.toFixed(1));
  console.log('');
  console.log('  render                                   vs        mean     p99     max');
  const row = (name, against, e) => console.log(`  ${name.padEnd(40)} ${against.padEnd(8)} ${e.mean.toFixed(3).padStart(6)} ${e.p99.toFixed(2).padStart(7)} ${e.max.toFixed(2).padStart(7)}`);
  row('normalmap (the PNG)', 'highres', nm);
  row('lowpoly (no normal map)', 'highres', bare);
  row('perVertexJs (map for three\'s frame)', 'highres', perVertex);
  row('perVertexFloat (the same, not rounded)', 'highres', perVertexFloat);
  row('perPixelJs (map for the per-pixel frame)', 'highres', perPixel);
  row('greenFlipped (normalScale.y = -1)', 'highres', flipped);
  console.log(`  over the ${nmWhereFramesDiffer.n} pixels of the ${result.differing.length} texels where the two frames' maps differ by more than one step:`);
  row('  normalmap (the PNG)', 'highres', nmWhereFramesDiffer);
  row('  perPixelJs (map for the per-pixel frame)', 'highres', perPixelWhereFramesDiffer);
  row('highres (standard) - lambert: specular', 'lambert', specular);
  row('lambert (MeshLambertMaterial)', 'expected', lambert);
  row('normalmap (the PNG)', 'expected', nmExpected);
  console.log(`  improvement: mean(lowpoly) / mean(normalmap) = ${(bare.mean / nm.mean).toFixed(1)} (required >= ${kMinImprovement})`);
  console.log('');
  console.log('  Low-poly meshes of the tile against highres, mean / p99: red channel with the normal map, without it (vertex normals),');
  console.log('  flat shaded (each triangle\'s own normal), and |height| in metres.');
  console.log('');
  console.log('  mesh                         triangles  max error   with map          without map       flat shaded       height (m)');
  const cell = (e) => `${e.mean.toFixed(2).padStart(6)} / ${e.p99.toFixed(1).padStart(5)}`.padEnd(18);
  for (const [name, m] of [['adaptive, 1 texel (default)', meshes.adaptive1], [`grid ${kGrid}`, meshes.grid],
    [`adaptive, --max-error ${meshes.adaptive.bound}`, meshes.adaptive]]) {
    const e = metrics[m === meshes.adaptive1 ? 'adaptive1' : m === meshes.grid ? 'grid' : 'adaptive'];
    console.log(`  ${name.padEnd(28)} ${String(m.triangles).padStart(9)} ${`${m.maxErrorM.toFixed(1)} m`.padStart(10)}   ` +
      `${cell(e.withMap)}${cell(e.withoutMap)}${cell(e.flat)}${cell(e.height)}`);
  }
  console.log('');
  console.log(`  page's map for three's frame vs the PNG: ${result.info.pngVsPerVertexJs.beyondOne} texels more than one 8-bit step apart, ` +
    `largest ${result.info.pngVsPerVertexJs.maxStep}`);
  console.log('');
  log(`renders and difference images (|difference| x 8) in ${out}`);

  if (coverage < kMinCoverage) fail(`the meshes overlap on ${(100 * coverage).toFixed(1)} % of the canvas, expected at least ${100 * kMinCoverage} %`);
  if (!(meanShade >= kMeanShadeRange[0] && meanShade <= kMeanShadeRange[1])) {
    fail(`mean shade of the high-res render ${meanShade.toFixed(1)} is outside ${kMeanShadeRange.join('..')}`);
  }
  if (!(lambert.mean <= kMaxMeanLambert && lambert.max <= kMaxLambert)) {
    fail(`the Lambert render is not max(0, n_high . sun): mean ${lambert.mean.toFixed(3)} (at most ${kMaxMeanLambert}), max ${lambert.max.toFixed(3)} (at most ${kMaxLambert})`);
  }
  if (result.info.pngVsPerVertexJs.beyondOne > kMaxTexelsBeyondOneStep) {
    fail(`the PNG differs from the page's normal map for three's frame by more than one 8-bit step at ${result.info.pngVsPerVertexJs.beyondOne} texels (at most ${kMaxTexelsBeyondOneStep})`);
  }
  if (!(bare.mean >= kMinMeanBare)) fail(`the bare low-poly mesh is within a mean of ${bare.mean.toFixed(2)} of the high-res one (expected at least ${kMinMeanBare}): the relief does not show`);
  if (!(nm.mean <= kMaxMeanNormalMap)) fail(`normal-mapped vs high-res: mean ${nm.mean.toFixed(3)} > ${kMaxMeanNormalMap}`);
  if (!(nm.p99 <= kMaxP99NormalMap)) fail(`normal-mapped vs high-res: p99 ${nm.p99.toFixed(2)} > ${kMaxP99NormalMap}`);
  if (!(flipped.mean > kMaxMeanNormalMap && flipped.p99 > kMaxP99NormalMap)) {
    fail(`the bounds do not tell a flipped green channel: mean ${flipped.mean.toFixed(2)}, p99 ${flipped.p99.toFixed(2)}`);
  }
  if (result.differing.length < kMinDifferingTexels) {
    fail(`the two frames' maps differ at only ${result.differing.length} texels (expected at least ${kMinDifferingTexels}): the frame check says nothing`);
  } else if (!(nmWhereFramesDiffer.mean * kMinFrameImprovement <= perPixelWhereFramesDiffer.mean)) {
    fail(`where the frames' maps differ, the PNG is within a mean of ${nmWhereFramesDiffer.mean.toFixed(2)} of the high-res render, ` +
      `the per-pixel frame's map ${perPixelWhereFramesDiffer.mean.toFixed(2)}: not ${kMinFrameImprovement} times closer`);
  }
  {
    const { grid, adaptive } = metrics;
    const { grid: g, adaptive: a } = meshes;
    for (const [name, e] of [['grid', grid], ['adaptive', adaptive]]) {
      if (!(e.withMap.mean <= kMaxMeanNormalMap && e.withMap.p99 <= kMaxP99NormalMap)) {
        fail(`${name} mesh, normal-mapped vs high-res: mean ${e.withMap.mean.toFixed(3)} (at most ${kMaxMeanNormalMap}), p99 ${e.withMap.p99.toFixed(2)} (at most ${kMaxP99NormalMap})`);
      }
    }
    if (!(a.triangles <= g.triangles)) fail(`the adaptive mesh has ${a.triangles} triangles, the grid ${g.triangles}: not a fair comparison`);
    if (!(typeof a.maxErrorM === 'number' && typeof g.maxErrorM === 'number')) {
      fail(`asset.extras.terrabake.max_error_m missing: adaptive ${a.maxErrorM}, grid ${g.maxErrorM}`);
    } else {
      if (!(a.maxErrorM <= a.bound + 1e-3)) fail(`the adaptive mesh's achieved error ${a.maxErrorM} m is over its bound ${a.bound} m`);
      if (!(a.maxErrorM <= kMaxAchievedErrorRatio * g.maxErrorM)) {
        fail(`the adaptive mesh's achieved error ${a.maxErrorM.toFixed(1)} m is not within ${kMaxAchievedErrorRatio} of the grid's ${g.maxErrorM.toFixed(1)} m`);
      }
    }
    for (const [what, key] of [['without the normal map', 'withoutMap'], ['flat shaded', 'flat'], ['heights', 'height']]) {
      if (!(adaptive[key].mean < grid[key].mean)) {
        fail(`${what}, the adaptive mesh is no closer to high-res than the grid at as many triangles: mean ${adaptive[key].mean.toFixed(2)} against ${grid[key].mean.toFixed(2)}`);
      }
    }
    if (!(adaptive.height.p99 <= kMaxHeightP99Ratio * grid.height.p99)) {
      fail(`heights: p99 ${adaptive.height.p99.toFixed(1)} m for the adaptive mesh, ${grid.height.p99.toFixed(1)} m for the grid (required at most ${kMaxHeightP99Ratio} times)`);
    }
  }
  if (!(nm.mean * kMinImprovement <= bare.mean)) {
    fail(`the normal map brings the low-poly mesh only ${(bare.mean / nm.mean).toFixed(1)} times closer to the high-res one (required ${kMinImprovement})`);
  }
}

await t.run(main);
