#!/usr/bin/env node
// Browser test of a layer's elevation tiles in MapLibre GL JS from npm, served
// by `terrabake serve` (src/server/viewer/maplibre.html): a raster-dem source
// from /<layer>/elevation.json drawn as hillshade and 3D terrain, in headless
// Chromium with nothing from the network.
//
//   node tests/browser/maplibre_test.mjs <terrabake executable> <output folder>
//
// 1. Tiles the sample DEM at zooms 9-12 twice, with Terrarium and with
//    Terrain-RGB (mapbox) elevation tiles.
// 2. The viewer page links a layer with elevation tiles to the MapLibre page.
// 3. Each view loads with no console error, page error or failed request, and
//    fetches .elevation.png tiles from the server.
// 4. Seen straight down at zoom 12, where the layer fills the view: the
//    hillshade is not uniform (standard deviation of luma), and it changes
//    when the sun comes from the south-east instead of the north-west (mean
//    absolute difference of luma). The Terrain-RGB layer looks as the
//    Terrarium one does: MapLibre reads each encoding from elevation.json.
// 5. Tilted, 3D terrain on differs from terrain off: setTerrain lifts the map.
//
// Exit code: 0 passed, 1 failed, 77 skipped (no Chromium or no playwright-core).
import path from 'node:path';

import { createBrowserTest, kRepo } from './browser_test_support.mjs';

const kTileTimeoutMs = 180_000;
const kPageTimeoutMs = 120_000;
const kWatchdogMs = 540_000;
const kViewport = { width: 800, height: 600 };

const kZooms = '9-12';
const kLayers = { terrarium: 'elevation_terrarium', mapbox: 'elevation_mapbox' };
// Straight down at zoom 12 on the middle of the sample DEM (30 km across): the
// layer fills the view, so every pixel is hillshade.
const kFlatView = { zoom: '12', pitch: '0', terrain: 'on' };
// Tilted, and the heights doubled, so that the relief moves the map visibly.
const kTiltedView = { zoom: '12', pitch: '60', bearing: '30', exaggeration: '2', sun: '315' };

// The hillshade must vary across the view: without the hillshade layer the
// view is the plain background, luma std-dev 0 (measured: 33.5 with it).
const kMinLumaStdDev = 10;
// The sun from the south-east instead of the north-west lights the other
// slopes: mean absolute luma difference (measured: 43.3).
const kMinSunDifference = 10;
// Terrain-RGB steps 0.1 m, Terrarium 1/256 m: the two hillshades differ by
// that rounding only (measured: 0.07; Terrarium tiles read as Terrain-RGB,
// the raster-dem default, give 56).
const kMaxEncodingDifference = 1;
// Tilted, terrain on against off: the relief moves and hides slopes
// (measured: 31.9).
const kMinTerrainDifference = 8;

const t = createBrowserTest('maplibre_test', { watchdogMs: kWatchdogMs });
const { fail, log } = t;

function lumaOf(image) {
  const { rgb } = image;
  const luma = new Float64Array(image.width * image.height);
  for (let p = 0; p < luma.length; ++p) luma[p] = 0.2126 * rgb[3 * p] + 0.7152 * rgb[3 * p + 1] + 0.0722 * rgb[3 * p + 2];
  return luma;
}

function stdDev(values) {
  let sum = 0;
  for (const v of values) sum += v;
  const mean = sum / values.length;
  let squares = 0;
  for (const v of values) squares += (v - mean) ** 2;
  return Math.sqrt(squares / values.length);
}

function meanAbsDifference(a, b) {
  let sum = 0;
  for (let p = 0; p < a.length; ++p) sum += Math.abs(a[p] - b[p]);
  return sum / a.length;
}

// Counts the .elevation.png requests Chromium sends; the pages open one at a time.
function countElevationRequests(context) {
  const counter = { count: 0 };
  context.on('request', (request) => {
    if (/\.elevation\.png$/.test(new URL(request.url()).pathname)) ++counter.count;
  });
  return counter;
}

// Opens the MapLibre page; resolves to {luma, requests} or null, with the
// screenshot in <out>/<name>.png.
async function screenshot(serverUrl, out, name, query, requestCounter) {
  const before = requestCounter.count;
  const url = `${serverUrl}viewer/maplibre.html?${new URLSearchParams(query)}`;
  return t.screenshotPage(url, out, name, {
    timeoutMs: kPageTimeoutMs,
    notReadyDetail: async (p) => p.locator('#status').textContent({ timeout: 1000 }).catch(() => ''),
  }, ({ image, ms, file }) => {
    const requests = requestCounter.count - before;
    log(`${name}: ${requests} elevation tile requests, ${ms} ms -> ${file}`);
    if (requests === 0) fail(`${name}: the page requested no .elevation.png tile`);
    return { luma: lumaOf(image), requests };
  });
}

// The viewer's page for a layer with elevation tiles links to the MapLibre page.
async function checkViewerLink(serverUrl, layer) {
  const { page, ok } = await t.openPage(`${serverUrl}?layer=${layer}&z=9`, 'viewer link', { timeoutMs: kPageTimeoutMs });
  if (ok) {
    const link = page.locator('#maplibre a');
    const href = await link.getAttribute('href');
    const expected = `/viewer/maplibre.html?layer=${layer}`;
    if (!(await link.isVisible())) fail('viewer: no visible MapLibre link for a layer with elevation tiles');
    if (href !== expected) fail(`viewer: the MapLibre link is ${href}, not ${expected}`);
    log(`viewer links ${layer} to ${href}`);
  }
  await t.closePage(page);
}

async function main() {
  const { terrabake, out, tilesDir } = await t.setUp('maplibre_test.mjs');
  const sample = path.join(kRepo, 'config/sample.yaml');
  for (const [encoding, layer] of Object.entries(kLayers)) {
    await t.tile(terrabake, ['--config', sample, '--zoom', kZooms, '--elevation', encoding, '--out', tilesDir, '--layer', layer],
      kTileTimeoutMs);
  }

  const server = await t.serve(terrabake, tilesDir);
  const context = await t.launchChromium({ viewport: kViewport });
  const requestCounter = countElevationRequests(context);

  await checkViewerLink(server.url, kLayers.terrarium);
  const northWest = await screenshot(server.url, out, 'terrarium_sun315', { layer: kLayers.terrarium, ...kFlatView, sun: '315' }, requestCounter);
  const southEast = await screenshot(server.url, out, 'terrarium_sun135', { layer: kLayers.terrarium, ...kFlatView, sun: '135' }, requestCounter);
  const mapbox = await screenshot(server.url, out, 'mapbox_sun315', { layer: kLayers.mapbox, ...kFlatView, sun: '315' }, requestCounter);
  const tilted = await screenshot(server.url, out, 'terrarium_tilted', { layer: kLayers.terrarium, ...kTiltedView, terrain: 'on' }, requestCounter);
  const tiltedFlat = await screenshot(server.url, out, 'terrarium_tilted_flat', { layer: kLayers.terrarium, ...kTiltedView, terrain: 'off' }, requestCounter);

  const measured = {};
  if (northWest) measured.stdDev = stdDev(northWest.luma);
  if (northWest && southEast) measured.sun = meanAbsDifference(northWest.luma, southEast.luma);
  if (northWest && mapbox) measured.encoding = meanAbsDifference(northWest.luma, mapbox.luma);
  if (tilted && tiltedFlat) measured.terrain = meanAbsDifference(tilted.luma, tiltedFlat.luma);

  const show = (value) => (value === undefined ? '-' : value.toFixed(2));
  console.log('');
  console.log(`  luma std-dev of the hillshade (sun 315):       ${show(measured.stdDev)} (at least ${kMinLumaStdDev})`);
  console.log(`  |sun 315 - sun 135|, mean luma:                ${show(measured.sun)} (at least ${kMinSunDifference})`);
  console.log(`  |Terrarium - Terrain-RGB|, mean luma:          ${show(measured.encoding)} (at most ${kMaxEncodingDifference})`);
  console.log(`  |terrain on - terrain off|, tilted, mean luma: ${show(measured.terrain)} (at least ${kMinTerrainDifference})`);
  console.log('');
  if (measured.stdDev !== undefined && !(measured.stdDev >= kMinLumaStdDev)) {
    fail(`the hillshade is uniform: luma std-dev ${measured.stdDev.toFixed(2)} (at least ${kMinLumaStdDev})`);
  }
  if (measured.sun !== undefined && !(measured.sun >= kMinSunDifference)) {
    fail(`turning the sun from 315 to 135 degrees changes the view by ${measured.sun.toFixed(2)} luma (at least ${kMinSunDifference})`);
  }
  if (measured.encoding !== undefined && !(measured.encoding <= kMaxEncodingDifference)) {
    fail(`Terrain-RGB tiles look unlike Terrarium ones: ${measured.encoding.toFixed(2)} luma apart (at most ${kMaxEncodingDifference})`);
  }
  if (measured.terrain !== undefined && !(measured.terrain >= kMinTerrainDifference)) {
    fail(`3D terrain changes the tilted view by ${measured.terrain.toFixed(2)} luma only (at least ${kMinTerrainDifference})`);
  }
  await t.stopServer(server);
}

await t.run(main);
