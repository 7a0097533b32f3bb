#!/usr/bin/env node
// Browser test of a layer's 3D Tiles in the viewers people run: three.js with
// 3d-tiles-renderer, and CesiumJS, both from npm, served by `terrabake serve`
// (src/server/viewer/tiles3d.html), in headless Chromium with nothing from
// the network.
//
//   node tests/browser/tileset_test.mjs <terrabake executable> <output folder>
//
// 1. Tiles the sample DEM at zooms 9-12 with output.tileset and high-res meshes.
// 2. For each viewer: loads the tileset with no console error, page error or
//    failed request; from far away it draws coarser levels than from close
//    by, close by it has fetched tiles of more than one level, and the three
//    views of step 3 draw the same levels.
// 3. For each viewer, one camera and sun: the normal-mapped tiles, the same
//    without their normal maps, and the .hires.glb meshes. Over the pixels
//    that are terrain in all three, the normal-mapped view must be closer to
//    the high-res one than the bare low-poly view is, by the mean absolute
//    difference of luma.
// 4. Cracks where levels meet: two layers with coarse meshes (so that the
//    edges of neighbouring levels differ by metres), one with skirts, one
//    without, seen in three.js from a camera that sees only terrain and draws
//    tiles of two levels side by side. The background (magenta) must not show
//    with skirts, and must show without (else the view proves nothing).
// 5. Across the antimeridian: the sample DEM set on a longitude/latitude grid
//    from 179.85 to 180.15 degrees (gdal_translate) and tiled on its own
//    grid, so that tiles and their parents span 180 degrees and the root is
//    bounded by a box; and tiled in Web Mercator from zoom 4, whose root box
//    spans 45 degrees. Each viewer, looking down at the layer's centre (the
//    middle of bounds that run across 180 degrees), must draw terrain over
//    the whole view.
//
// Exit code: 0 passed, 1 failed, 77 skipped (no Chromium or no playwright-core).
import path from 'node:path';

import { createBrowserTest, kRepo } from './browser_test_support.mjs';

const kTileTimeoutMs = 180_000;
const kPageTimeoutMs = 180_000;
const kWatchdogMs = 540_000;
const kViewport = { width: 800, height: 600 };

const kLayer = 'sample3d';
const kZooms = '9-12';
// Looking down at the middle of the sample DEM (30 km across) at 55 degrees:
// every pixel is terrain, and the tiles near the camera are at the deepest zoom.
const kView = { camAz: '200', camEl: '55', camDist: '9000', fov: '40', az: '315', el: '35', sse: '8' };
const kFarView = { ...kView, camEl: '89', camDist: '120000', sse: '16' };
// The normal maps must bring the low-poly tiles at least this much closer to
// the high-res meshes than they are without them, as in the viewer test
// (measured: 10.8x in three.js, 11.1x in CesiumJS).
const kRequiredImprovement = 3;
// Terrain must cover at least this share of each comparison view.
const kMinTerrainShare = 0.9;
// Crack layers: meshes within 6 texels of their samples (not the default 1),
// so that two levels' edges part by tens of metres.
const kCoarseErrorTexels = '6';
// A lower camera, further off, whose far tiles are a level coarser than its
// near ones (measured: 382 background pixels along their seams without skirts).
const kCrackView = { ...kView, camEl: '35', camDist: '9000', sse: '16' };
const kAntimeridianLayer = 'antimeridian';
// The same DEM in Web Mercator from zoom 4, whose tiles span 22.5 degrees:
// the root's box, across the antimeridian, has its centre hundreds of
// kilometres below the surface (the view once looked at that depth in three.js
// and drew nothing).
const kWideAntimeridianLayer = 'antimeridian_wide';
const kWideAntimeridianZooms = '4-9';
// The sample's pixels on a 0.3 x 0.2 degree grid (23 x 22 km at 46.5 N).
const kAntimeridianBounds = ['179.85', '46.6', '-179.85', '46.4'];
const kAntimeridianView = { ...kView, camEl: '70', camDist: '6000' };
// Skirts must hide every gap; without them at least this many background
// pixels must show through, or the view shows no gap to hide.
const kMaxCrackPixelsWithSkirts = 0;
const kMinCrackPixelsWithoutSkirts = 50;

const t = createBrowserTest('tileset_test', { watchdogMs: kWatchdogMs });
const { fail, log } = t;

function isBackground(rgb, p) {
  return rgb[3 * p] > 200 && rgb[3 * p + 1] < 60 && rgb[3 * p + 2] > 200;
}

function luma(rgb, p) {
  return 0.2126 * rgb[3 * p] + 0.7152 * rgb[3 * p + 1] + 0.0722 * rgb[3 * p + 2];
}

// Opens the view; resolves to {image, stats} or null, with the screenshot in <out>/<name>.png.
async function screenshot(serverUrl, out, name, query) {
  const url = `${serverUrl}viewer/tiles3d.html?${new URLSearchParams(query)}`;
  return t.screenshotPage(url, out, name, {
    timeoutMs: kPageTimeoutMs,
    // 3D Tiles viewers cancel the downloads of tiles the view no longer needs.
    cancelledRequestsAllowed: true,
    notReadyDetail: async (p) => p.locator('#status').textContent({ timeout: 1000 }).catch(() => ''),
  }, async ({ page, image, ms, file }) => {
    const stats = await page.evaluate(() => window.terrabakeStats);
    log(`${name}: levels drawn ${stats.visibleLevels.join(',')}, fetched ${stats.requestedLevels.join(',')}, ${ms} ms -> ${file}`);
    return { image, stats };
  });
}

function countBackground(image) {
  let n = 0;
  for (let p = 0; p < image.width * image.height; ++p) n += isBackground(image.rgb, p) ? 1 : 0;
  return n;
}

async function checkViewer(serverUrl, out, renderer) {
  const far = await screenshot(serverUrl, out, `${renderer}_far`, { layer: kLayer, renderer, ...kFarView });
  const shots = {};
  for (const mode of ['normalmap', 'lowpoly', 'highres']) {
    shots[mode] = await screenshot(serverUrl, out, `${renderer}_${mode}`, { layer: kLayer, renderer, mode, ...kView });
  }
  if (!far || !shots.normalmap || !shots.lowpoly || !shots.highres) return null;

  const nearLevels = shots.normalmap.stats.visibleLevels;
  if (!(Math.max(...far.stats.visibleLevels) < Math.max(...nearLevels))) {
    fail(`${renderer}: the close view draws levels ${nearLevels}, the far one ${far.stats.visibleLevels}: no finer level closer by`);
  }
  // One camera, one tileset: each mode must show the same levels, or the
  // page declared itself ready before the view had refined.
  for (const mode of ['lowpoly', 'highres']) {
    if (shots[mode].stats.visibleLevels.join() !== nearLevels.join()) {
      fail(`${renderer}: ${mode} draws levels ${shots[mode].stats.visibleLevels}, normalmap ${nearLevels}: not the same view`);
    }
  }
  if (shots.normalmap.stats.requestedLevels.length < 2) {
    fail(`${renderer}: fetched tiles of levels ${shots.normalmap.stats.requestedLevels} only`);
  }

  const { width, height } = shots.normalmap.image;
  let terrain = 0;
  let normalMapped = 0;
  let bare = 0;
  for (let p = 0; p < width * height; ++p) {
    if (Object.values(shots).some((s) => isBackground(s.image.rgb, p))) continue;
    ++terrain;
    const reference = luma(shots.highres.image.rgb, p);
    normalMapped += Math.abs(luma(shots.normalmap.image.rgb, p) - reference);
    bare += Math.abs(luma(shots.lowpoly.image.rgb, p) - reference);
  }
  const share = terrain / (width * height);
  if (share < kMinTerrainShare) fail(`${renderer}: terrain covers ${(100 * share).toFixed(1)}% of the view (at least ${100 * kMinTerrainShare}%)`);
  const result = { renderer, share, normalMapped: normalMapped / terrain, bare: bare / terrain };
  if (!(result.bare >= kRequiredImprovement * result.normalMapped)) {
    fail(`${renderer}: normal-mapped tiles differ from the high-res ones by ${result.normalMapped.toFixed(2)} luma, ` +
      `bare low-poly tiles by ${result.bare.toFixed(2)}: not ${kRequiredImprovement}x closer`);
  }
  return result;
}

async function main() {
  const { terrabake, out, tilesDir } = await t.setUp('tileset_test.mjs');
  const sample = path.join(kRepo, 'config/sample.yaml');
  await t.tile(terrabake, ['--config', sample, '--zoom', kZooms, '--tileset', 'true', '--high-res-mesh', 'true',
    '--out', tilesDir, '--layer', kLayer], kTileTimeoutMs);
  for (const skirts of ['on', 'off']) {
    await t.tile(terrabake, ['--config', sample, '--zoom', kZooms, '--tileset', 'true', '--skirts', skirts,
      '--max-error-texels', kCoarseErrorTexels, '--out', tilesDir, '--layer', `skirts_${skirts}`], kTileTimeoutMs);
  }

  const acrossDem = path.join(out, 'sample_across_180.tif');
  const [west, north, east, south] = kAntimeridianBounds;
  const translated = await t.runToEnd('gdal_translate', ['-q', '-a_srs', 'EPSG:4326', '-a_ullr', west, north,
    String(Number(east) + 360), south, path.join(kRepo, 'tests/data/sample_dem.tif'), acrossDem], kTileTimeoutMs);
  if (translated.code !== 0) await t.abort(`gdal_translate ended with code ${translated.code}:\n${translated.output}`);
  await t.tile(terrabake, ['--dem', acrossDem, '--scheme', 'native', '--zoom', 'auto', '--tileset', 'true',
    '--out', tilesDir, '--layer', kAntimeridianLayer], kTileTimeoutMs);
  await t.tile(terrabake, ['--dem', acrossDem, '--zoom', kWideAntimeridianZooms, '--tile-size', '64', '--tileset', 'true',
    '--out', tilesDir, '--layer', kWideAntimeridianLayer], kTileTimeoutMs);

  const server = await t.serve(terrabake, tilesDir);
  await t.launchChromium({ viewport: kViewport });

  const results = [];
  for (const renderer of ['three', 'cesium']) {
    const result = await checkViewer(server.url, out, renderer);
    if (result) results.push(result);
  }

  const cracks = {};
  for (const skirts of ['on', 'off']) {
    const shot = await screenshot(server.url, out, `three_cracks_skirts_${skirts}`,
      { layer: `skirts_${skirts}`, renderer: 'three', ...kCrackView });
    if (!shot) continue;
    if (shot.stats.visibleLevels.length < 2) fail(`cracks, skirts ${skirts}: draws levels ${shot.stats.visibleLevels} only; the view needs two`);
    cracks[skirts] = countBackground(shot.image);
  }

  const across = {};
  for (const layer of [kAntimeridianLayer, kWideAntimeridianLayer]) {
    for (const renderer of ['three', 'cesium']) {
      const shot = await screenshot(server.url, out, `${renderer}_${layer}`, { layer, renderer, ...kAntimeridianView });
      if (!shot) continue;
      const { width, height } = shot.image;
      const key = `${renderer} ${layer}`;
      across[key] = 1 - countBackground(shot.image) / (width * height);
      if (across[key] < kMinTerrainShare) {
        fail(`${renderer}, ${layer} across the antimeridian: terrain covers ${(100 * across[key]).toFixed(1)}% of ` +
          `the view (at least ${100 * kMinTerrainShare}%)`);
      }
    }
  }

  console.log('');
  console.log('  viewer   terrain   |normal-mapped - high-res|   |low-poly - high-res|   ratio');
  for (const r of results) {
    console.log(`  ${r.renderer.padEnd(8)} ${(100 * r.share).toFixed(1).padStart(6)}%   ${r.normalMapped.toFixed(2).padStart(24)}   ` +
      `${r.bare.toFixed(2).padStart(21)}   ${(r.bare / r.normalMapped).toFixed(2)}`);
  }
  console.log(`  background pixels where levels meet: skirts on ${cracks.on ?? '-'}, skirts off ${cracks.off ?? '-'}`);
  const share = (key) => (across[key] === undefined ? '-' : `${(100 * across[key]).toFixed(1)}%`);
  for (const layer of [kAntimeridianLayer, kWideAntimeridianLayer]) {
    console.log(`  terrain across the antimeridian, ${layer}: three ${share(`three ${layer}`)}, ` +
      `cesium ${share(`cesium ${layer}`)}`);
  }
  console.log('');
  if (cracks.on !== undefined && cracks.on > kMaxCrackPixelsWithSkirts) {
    fail(`cracks: ${cracks.on} background pixels show through with skirts (at most ${kMaxCrackPixelsWithSkirts})`);
  }
  if (cracks.off !== undefined && cracks.off < kMinCrackPixelsWithoutSkirts) {
    fail(`cracks: only ${cracks.off} background pixels without skirts (at least ${kMinCrackPixelsWithoutSkirts}): the view shows no gap`);
  }
  await t.stopServer(server);
}

await t.run(main);
