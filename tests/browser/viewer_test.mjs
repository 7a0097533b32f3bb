#!/usr/bin/env node
// Browser test of the viewer that `terrabake serve` serves (src/server/viewer/).
//
//   node tests/browser/viewer_test.mjs <terrabake executable> <output folder>
//
// 1. Tiles the sample DEM at zoom 12 with high-res meshes into <out>/tiles/sample/.
// 2. Starts `terrabake serve --tiles <out>/tiles --port 0` and reads the port it prints.
// 3. Opens the viewer in headless Chromium (SwiftShader WebGL, fresh profile):
//    first as a user would (no URL parameters), then in its deterministic mode,
//    with one camera and one sun, as mode=normalmap, mode=lowpoly and mode=highres.
//    Any console error, page error, failed request or HTTP error fails the test.
//    The low-poly modes show as many triangles as the layer's .glb files hold
//    (the adaptive mesh, the default, has its own count in each tile); the
//    normal-mapped view again with wireframe=1 shows the triangles: the same
//    count, and a clearly different picture.
// 4. Compares the screenshots over the pixels that show terrain in all three:
//    the normal-mapped low-poly tiles must be at least 3 times closer to the
//    high-res meshes than the bare low-poly tiles are, by the mean absolute
//    difference of luma (0..255). RMSE is printed too; it weighs the few pixels
//    on sunlit/shaded ridge crests that parallax shifts by a pixel (the low-poly
//    surface is not at the high-res height) far more than the shading itself.
// 5. A view across the DEM's west edge, from above, of the layer and of a
//    second one made with --nodata-surface cut. The cut view draws nothing
//    beyond the data (alpha cuts at texels, so its terrain ends along a smooth
//    line, not in mesh cells) and the data as the default view does; that line
//    locates the edge in the default view, where the luma profile across it,
//    averaged along it, must dip no deeper than profiles across lines inside
//    the terrain do: no dark line where the data stops.
// 6. Keeps the screenshots and difference images in <out>/ and stops the server
//    with SIGTERM.
//
// Exit code: 0 passed, 1 failed, 77 skipped (no Chromium or no playwright-core;
// `cd tests && npm ci` installs the latter). CHROMIUM=<path> picks another browser.
import { readdir, readFile, writeFile } from 'node:fs/promises';
import path from 'node:path';

import { createBrowserTest, decodePng, encodePngRgb, kRepo } from './browser_test_support.mjs';

// Limits. The whole test takes about 40 s on the 2-core development machine.
const kTileTimeoutMs = 180_000;
const kPageTimeoutMs = 180_000;   // 16 high-res tiles (2.1 M triangles) load and draw in ~10 s
const kWatchdogMs = 540_000;      // everything, including cleanup

// The view the comparison uses. The 16 tiles nearest the centre are the 4 x 4
// block that the DEM covers completely; a sun 35 degrees high from the
// north-west (both horizontal components non-zero, so a flipped red or green
// channel changes the picture) and a steep camera, 75 degrees above the
// horizon (little parallax between the low-poly and high-res surfaces), make
// the shading the main difference.
const kView = {
  layer: 'sample', z: '12', maxTiles: '16', width: '960', height: '640',
  az: '315', el: '35', camAz: '180', camEl: '75', camDist: '0.9', fov: '35',
  // TERRABAKE_VIEWER_TEST_VIEW='camEl=70&az=90' overrides any of these, for experiments.
  ...Object.fromEntries(new URLSearchParams(process.env.TERRABAKE_VIEWER_TEST_VIEW || '')),
};
const kModes = ['normalmap', 'lowpoly', 'highres'];
// The edge view: the four tiles nearest the middle of the DEM's west edge,
// seen from straight above (89 degrees: the orbit controls need a horizon),
// close enough for about two pixels a texel.
const kEdgeView = { ...kView, maxTiles: '4', camAz: '180', camEl: '89', camDist: '0.55', mode: 'normalmap' };
const kCutLayer = 'sample_cut';
// Luma profiles across the edge (and across the control lines) run this many
// pixels either side; the dip is the darkest pixel within kDipHalfWidthPx of
// the line against the mean of the flanks beyond kFlankStartPx.
const kProfileHalfWidthPx = 14;
const kDipHalfWidthPx = 3;
const kFlankStartPx = 5;
// Control lines: parallel to the edge, this far inside the terrain.
const kControlOffsetsPx = [24, 40, 56, 72, 88, 104, 120];
// The cut view's terrain starts along the edge, which parallax bends smoothly:
// from one row to the next by at most this many pixels (two texels). Cut at
// mesh cells, it would jump by 16 texels where it crosses one.
const kMaxCutEdgeJumpPx = 4;
// Where the cut view draws, it draws what the default view does: the mean
// luma difference there, a few pixels clear of the edge's antialiasing.
const kMaxCutDifference = 0.5;
const kCutEdgeClearancePx = 3;
// Rows whose edge was found must make up this share of the edge view.
const kMinEdgeRowShare = 0.5;
const kHighResTrianglesPerTile = 2 * 256 * 256;   // tile_size 256
// wireframe=1 draws the triangles' edges over the background: at least this
// share of the pixels that are terrain with wireframe=0 must change by more
// than kWireframeLumaStep.
const kMinWireframeChange = 0.2;
const kWireframeLumaStep = 8;
// The normal map must bring the low-poly tiles at least this much closer to the
// high-res surface than they are without it.
const kRequiredImprovement = 3;
// Without the normal map the picture must differ visibly (mean absolute luma
// difference, 0..255), or the comparison says nothing.
const kMinLowPolyError = 3;
// Terrain must cover at least this share of the canvas.
const kMinTerrainShare = 0.25;
// A pixel is terrain when its channels differ by at most this much: the
// terrain is lit neutral grey, the background is light blue (170, 200, 230).
const kGreyTolerance = 4;

const t = createBrowserTest('viewer_test', { watchdogMs: kWatchdogMs });
const { fail, log } = t;

// ---------------------------------------------------------------------------
// Image metrics

// Rec. 709 luma of the 8-bit sRGB values on screen, 0..255.
function luma(rgb, p) {
  return 0.2126 * rgb[3 * p] + 0.7152 * rgb[3 * p + 1] + 0.0722 * rgb[3 * p + 2];
}

function isGrey(rgb, p) {
  const r = rgb[3 * p];
  const g = rgb[3 * p + 1];
  const b = rgb[3 * p + 2];
  return Math.max(r, g, b) - Math.min(r, g, b) <= kGreyTolerance;
}

function compare(a, b, mask) {
  let sum2 = 0;
  let sum1 = 0;
  let n = 0;
  for (let p = 0; p < mask.length; ++p) {
    if (!mask[p]) continue;
    const d = luma(a.rgb, p) - luma(b.rgb, p);
    sum2 += d * d;
    sum1 += Math.abs(d);
    ++n;
  }
  return { rmse: Math.sqrt(sum2 / n), mae: sum1 / n };
}

// |a - b| of luma, times 4, as a grey image; background black.
function diffImage(a, b, mask) {
  const out = Buffer.alloc(a.rgb.length);
  for (let p = 0; p < mask.length; ++p) {
    const v = mask[p] ? Math.min(255, Math.round(4 * Math.abs(luma(a.rgb, p) - luma(b.rgb, p)))) : 0;
    out[3 * p] = out[3 * p + 1] = out[3 * p + 2] = v;
  }
  return encodePngRgb(a.width, a.height, out);
}

// Triangles of each low-poly .glb of layer/z under tilesDir, in no order.
async function lowPolyTriangles(tilesDir, layer, z) {
  const counts = [];
  const zDir = path.join(tilesDir, layer, String(z));
  for (const x of await readdir(zDir)) {
    for (const name of await readdir(path.join(zDir, x))) {
      if (!name.endsWith('.glb') || name.endsWith('.hires.glb')) continue;
      const bytes = await readFile(path.join(zDir, x, name));
      const json = JSON.parse(bytes.subarray(20, 20 + bytes.readUInt32LE(12)).toString('utf8'));
      counts.push(json.accessors[json.meshes[0].primitives[0].indices].count / 3);
    }
  }
  return counts;
}

// ---------------------------------------------------------------------------
// Browser

// Opens the viewer at url (failures as t.openPage says); resolves to
// {page, stats, ms, ok} with the viewer's window.terrabakeStats.
async function openViewer(url, name) {
  const opened = await t.openPage(url, name, {
    timeoutMs: kPageTimeoutMs,
    notReadyDetail: async (page) => {
      const status = await page.locator('#status').textContent({ timeout: 1000 }).catch(() => '');
      return status ? `viewer status: ${status}` : '';
    },
  });
  const stats = opened.ok ? await opened.page.evaluate(() => window.terrabakeStats).catch(() => null) : null;
  return { ...opened, stats };
}

// ---------------------------------------------------------------------------
// The view across the DEM's edge

// Opens the edge view of `layer`; resolves to its decoded screenshot (saved
// as <out>/<name>.png) or null.
async function edgeScreenshot(serverUrl, layer, centre, out, name) {
  const query = new URLSearchParams({ ...kEdgeView, layer, center: `${centre[0]},${centre[1]}`, wireframe: '0' });
  const { page, stats, ok } = await openViewer(`${serverUrl}?${query}`, name);
  const file = path.join(out, `${name}.png`);
  let image = null;
  try {
    image = decodePng(await page.locator('#view canvas').screenshot({ path: file, timeout: 30_000 }));
  } catch (error) {
    fail(`${name}: screenshot: ${error.message}`);
  }
  await page.close();
  if (ok && stats && stats.tiles !== Number(kEdgeView.maxTiles)) fail(`${name}: ${stats.tiles} tiles shown, expected ${kEdgeView.maxTiles}`);
  log(`${name}: ${stats ? `${stats.tiles} tiles, ${stats.triangles} triangles` : 'not ready'} -> ${file}`);
  return ok ? image : null;
}

// Mean luma of `image` along the rows, at x = edge[y] + offset + k for k in
// -kProfileHalfWidthPx..kProfileHalfWidthPx; null where a row leaves the image.
function meanProfile(image, edge, offset) {
  const sum = new Array(2 * kProfileHalfWidthPx + 1).fill(0);
  let rows = 0;
  for (const [y, x] of edge) {
    const x0 = Math.round(x + offset) - kProfileHalfWidthPx;
    if (x0 < 0 || x0 + 2 * kProfileHalfWidthPx >= image.width) return null;
    for (let k = 0; k < sum.length; ++k) sum[k] += luma(image.rgb, y * image.width + x0 + k);
    ++rows;
  }
  return sum.map((s) => s / rows);
}

// How much darker the profile's middle is than the darker of its flanks
// (0 when it is not).
function dipDepth(profile) {
  const c = kProfileHalfWidthPx;
  const mean = (ks) => ks.reduce((s, k) => s + profile[c + k], 0) / ks.length;
  const range = (a, b) => Array.from({ length: b - a + 1 }, (_, i) => a + i);
  const flank = Math.min(mean(range(-kProfileHalfWidthPx, -kFlankStartPx)), mean(range(kFlankStartPx, kProfileHalfWidthPx)));
  const middle = Math.min(...range(-kDipHalfWidthPx, kDipHalfWidthPx).map((k) => profile[c + k]));
  return Math.max(0, flank - middle);
}

async function checkEdgeView(serverUrl, out) {
  let tilejson;
  try {
    tilejson = await (await fetch(`${serverUrl}${kView.layer}/tilejson.json`)).json();
  } catch (error) {
    fail(`edge view: cannot read the tilejson: ${error.message}`);
    return;
  }
  const [west, south, , north] = tilejson.bounds;
  const centre = [west, (south + north) / 2];
  const continued = await edgeScreenshot(serverUrl, kView.layer, centre, out, 'viewer_edge');
  const cut = await edgeScreenshot(serverUrl, kCutLayer, centre, out, 'viewer_edge_cut');
  if (!continued || !cut) return;

  // The edge, row by row: where the cut view's terrain starts.
  const edge = [];
  for (let y = 0; y < cut.height; ++y) {
    for (let x = 0; x < cut.width; ++x) {
      if (isGrey(cut.rgb, y * cut.width + x)) {
        if (x > 0) edge.push([y, x]);
        break;
      }
    }
  }
  if (edge.length < kMinEdgeRowShare * cut.height) {
    fail(`edge view: the cut view shows the DEM's edge on ${edge.length} of ${cut.height} rows`);
    return;
  }
  let jump = 0;
  for (let k = 1; k < edge.length; ++k) {
    if (edge[k][0] === edge[k - 1][0] + 1) jump = Math.max(jump, Math.abs(edge[k][1] - edge[k - 1][1]));
  }
  let difference = 0;
  let drawn = 0;
  for (const [y, x] of edge) {
    for (let xx = x + kCutEdgeClearancePx; xx < cut.width; ++xx) {
      const p = y * cut.width + xx;
      if (!isGrey(cut.rgb, p)) continue;
      difference += Math.abs(luma(cut.rgb, p) - luma(continued.rgb, p));
      ++drawn;
    }
  }
  difference /= drawn;

  const profile = meanProfile(continued, edge, 0);
  const controls = kControlOffsetsPx.map((offset) => meanProfile(continued, edge, offset)).filter(Boolean);
  const dip = profile ? dipDepth(profile) : NaN;
  const controlDips = controls.map(dipDepth);
  const worstControl = Math.max(...controlDips);
  console.log('');
  console.log(`  Edge view: the DEM's west edge on ${edge.length} rows of the cut view, moving at most ${jump} px from row to row;` +
    ` mean luma difference to the default view where the cut view draws ${difference.toFixed(3)}.`);
  console.log(`  Mean luma across the edge (${-kProfileHalfWidthPx}..${kProfileHalfWidthPx} px): ${profile ? profile.map((v) => v.toFixed(0)).join(' ') : '-'}`);
  console.log(`  Dip at the edge ${dip.toFixed(2)}; across lines ${kControlOffsetsPx.join(', ')} px inside the terrain ` +
    `${controlDips.map((d) => d.toFixed(2)).join(', ')} (largest ${worstControl.toFixed(2)})`);
  console.log('');
  if (jump > kMaxCutEdgeJumpPx) fail(`edge view: the cut view's terrain edge jumps ${jump} px between rows (at most ${kMaxCutEdgeJumpPx})`);
  if (!(difference <= kMaxCutDifference)) fail(`edge view: where the cut view draws, it differs from the default view by ${difference.toFixed(3)} (at most ${kMaxCutDifference})`);
  if (!profile || controls.length < 3) {
    fail('edge view: the profiles across the edge do not fit in the view');
  } else if (!(dip <= worstControl)) {
    fail(`edge view: a dark line along the DEM's edge: the luma dips ${dip.toFixed(2)} there, at most ${worstControl.toFixed(2)} across lines inside the terrain`);
  }
}

// ---------------------------------------------------------------------------

async function main() {
  const { terrabake, out, tilesDir } = await t.setUp('viewer_test.mjs');

  // 1. A small layer.
  await t.tile(terrabake, ['--config', path.join(kRepo, 'config/sample.yaml'), '--zoom', kView.z,
    '--high-res-mesh', 'true', '--out', tilesDir, '--layer', kView.layer], kTileTimeoutMs);
  await t.tile(terrabake, ['--config', path.join(kRepo, 'config/sample.yaml'), '--zoom', kView.z,
    '--nodata-surface', 'cut', '--out', tilesDir, '--layer', kCutLayer], kTileTimeoutMs);

  // 2. The server.
  const server = await t.serve(terrabake, tilesDir);

  // 3. The browser, with a fresh profile and nothing from the network.
  // Room for the panel (220 px) beside the fixed-size canvas.
  await t.launchChromium({
    viewport: { width: Number(kView.width) + 280, height: Math.max(700, Number(kView.height) + 40) },
  });

  // As a user opens it: default layer and zoom, canvas filling the window.
  {
    const { page, stats, ms } = await openViewer(server.url, 'viewer (no parameters)');
    const file = path.join(out, 'viewer_default.png');
    await page.screenshot({ path: file }).catch((error) => fail(`screenshot ${file}: ${error.message}`));
    log(`viewer (no parameters): ${stats ? `${stats.tiles} tiles, ${stats.triangles} triangles` : 'not ready'}, ${ms} ms -> ${file}`);
    if (stats && !(stats.tiles > 0 && stats.triangles > 0)) fail(`viewer (no parameters) shows nothing: ${JSON.stringify(stats)}`);
    await t.closePage(page);
  }

  // 4. One camera and sun, three kinds of mesh, and the normal-mapped view as
  // a wireframe.
  // The low-poly tiles shown must hold as many triangles as some maxTiles of
  // the layer's .glb files do: between the fewest and the most.
  const lowCounts = (await lowPolyTriangles(tilesDir, kView.layer, kView.z)).sort((a, b) => a - b);
  const sum = (list) => list.reduce((s, v) => s + v, 0);
  const lowRange = [sum(lowCounts.slice(0, Number(kView.maxTiles))), sum(lowCounts.slice(-Number(kView.maxTiles)))];
  const images = {};
  const rows = [];
  const lowPolyStats = [];
  for (const [mode, wireframe] of [...kModes.map((m) => [m, '0']), ['normalmap', '1']]) {
    const query = new URLSearchParams({ ...kView, mode, wireframe });
    const url = `${server.url}?${query}`;
    const name = wireframe === '1' ? `${mode}_wireframe` : mode;
    const { page, stats, ms, ok } = await openViewer(url, `mode=${mode}&wireframe=${wireframe}`);
    const file = path.join(out, `viewer_${name}.png`);
    try {
      const png = await page.locator('#view canvas').screenshot({ path: file, timeout: 30_000 });
      images[name] = decodePng(png);
    } catch (error) {
      fail(`${name}: screenshot: ${error.message}`);
    }
    await t.closePage(page);
    rows.push({ mode: name, stats, ms, file });
    if (!ok || !stats) continue;
    const expectedTiles = Number(kView.maxTiles);
    if (stats.tiles !== expectedTiles) fail(`${name}: ${stats.tiles} tiles shown, expected ${expectedTiles}`);
    if (mode === 'highres') {
      if (stats.triangles !== stats.tiles * kHighResTrianglesPerTile) {
        fail(`${name}: ${stats.triangles} triangles for ${stats.tiles} tiles, expected ${kHighResTrianglesPerTile} a tile`);
      }
    } else {
      lowPolyStats.push(stats.triangles);
      if (!(stats.triangles >= lowRange[0] && stats.triangles <= lowRange[1])) {
        fail(`${name}: ${stats.triangles} triangles for ${stats.tiles} tiles; ${expectedTiles} of the layer's .glb files hold ${lowRange.join(' to ')}`);
      }
    }
  }
  if (new Set(lowPolyStats).size > 1) fail(`the low-poly views show different triangle counts: ${lowPolyStats.join(', ')}`);
  if (images.normalmap && images.normalmap_wireframe) {
    const { width, height } = images.normalmap;
    let terrain = 0;
    let changed = 0;
    for (let p = 0; p < width * height; ++p) {
      if (!isGrey(images.normalmap.rgb, p)) continue;
      ++terrain;
      if (Math.abs(luma(images.normalmap.rgb, p) - luma(images.normalmap_wireframe.rgb, p)) > kWireframeLumaStep) ++changed;
    }
    const share = changed / Math.max(1, terrain);
    log(`wireframe=1 changes ${(100 * share).toFixed(1)} % of the terrain pixels of wireframe=0 by more than ${kWireframeLumaStep} in luma`);
    if (!(share >= kMinWireframeChange)) fail(`wireframe=1 changes only ${(100 * share).toFixed(1)} % of the terrain pixels (at least ${100 * kMinWireframeChange} %): no triangles drawn`);
  }
  log(`view: ${new URLSearchParams(kView)}`);
  console.log('');
  console.log('  mode                 tiles   triangles   load+draw   screenshot');
  for (const { mode, stats, ms, file } of rows) {
    console.log(`  ${mode.padEnd(19)} ${String(stats?.tiles ?? '-').padStart(6)} ${String(stats?.triangles ?? '-').padStart(11)} ${`${(ms / 1000).toFixed(1)} s`.padStart(11)}   ${file}`);
  }
  console.log('');

  // 5. The metric.
  if (kModes.every((mode) => images[mode])) {
    const { width, height } = images.highres;
    if (kModes.some((mode) => images[mode].width !== width || images[mode].height !== height)) {
      fail(`screenshots differ in size: ${kModes.map((m) => `${images[m].width}x${images[m].height}`).join(', ')}`);
    } else {
      const mask = new Uint8Array(width * height);
      let terrain = 0;
      let dark = 0;
      for (let p = 0; p < mask.length; ++p) {
        if (kModes.every((mode) => isGrey(images[mode].rgb, p))) {
          mask[p] = 1;
          ++terrain;
          if (kModes.some((mode) => luma(images[mode].rgb, p) < 8)) ++dark;
        }
      }
      const share = terrain / mask.length;
      const nmHr = compare(images.normalmap, images.highres, mask);
      const lpHr = compare(images.lowpoly, images.highres, mask);
      const nmLp = compare(images.normalmap, images.lowpoly, mask);
      const means = Object.fromEntries(kModes.map((mode) => {
        let sum = 0;
        for (let p = 0; p < mask.length; ++p) if (mask[p]) sum += luma(images[mode].rgb, p);
        return [mode, sum / terrain];
      }));
      console.log(`  Luma error over the ${terrain} pixels that are terrain in all three screenshots ` +
        `(${(100 * share).toFixed(1)} % of ${width} x ${height});`);
      console.log('  luma Y = 0.2126 R + 0.7152 G + 0.0722 B of the 8-bit sRGB screenshot, 0..255.');
      console.log('');
      console.log('  pair                      MAE    RMSE');
      for (const [name, e] of [['normalmap vs highres', nmHr], ['lowpoly   vs highres', lpHr], ['normalmap vs lowpoly', nmLp]]) {
        console.log(`  ${name.padEnd(22)} ${e.mae.toFixed(2).padStart(6)}  ${e.rmse.toFixed(2).padStart(6)}`);
      }
      console.log('');
      console.log(`  mean luma: ${kModes.map((m) => `${m} ${means[m].toFixed(1)}`).join(', ')}`);
      console.log(`  MAE(lowpoly vs highres) / MAE(normalmap vs highres) = ${(lpHr.mae / nmHr.mae).toFixed(2)} ` +
        `(required >= ${kRequiredImprovement}); RMSE ratio ${(lpHr.rmse / nmHr.rmse).toFixed(2)} (not checked)`);
      console.log('');

      await writeFile(path.join(out, 'diff_normalmap_highres.png'), diffImage(images.normalmap, images.highres, mask));
      await writeFile(path.join(out, 'diff_lowpoly_highres.png'), diffImage(images.lowpoly, images.highres, mask));
      log(`difference images (|luma| x 4): ${path.join(out, 'diff_normalmap_highres.png')}, ${path.join(out, 'diff_lowpoly_highres.png')}`);

      if (share < kMinTerrainShare) fail(`terrain covers ${(100 * share).toFixed(1)} % of the canvas, expected at least ${100 * kMinTerrainShare} %`);
      if (dark > 0) fail(`${dark} terrain pixels are black (luma < 8): unlit or garbage`);
      for (const mode of kModes) {
        if (!(means[mode] > 40 && means[mode] < 220)) fail(`mode=${mode}: mean terrain luma ${means[mode].toFixed(1)} is outside 40..220`);
      }
      if (!(lpHr.mae >= kMinLowPolyError)) {
        fail(`low-poly without its normal map is too close to high-res (MAE ${lpHr.mae.toFixed(2)} < ${kMinLowPolyError}): the relief does not show`);
      }
      if (!(nmHr.mae * kRequiredImprovement <= lpHr.mae)) {
        fail(`MAE(normalmap vs highres) * ${kRequiredImprovement} = ${(nmHr.mae * kRequiredImprovement).toFixed(2)} > MAE(lowpoly vs highres) = ${lpHr.mae.toFixed(2)}`);
      }
    }
  } else {
    fail('not every mode gave a screenshot; nothing to compare');
  }

  // 5. Across the DEM's edge.
  await checkEdgeView(server.url, out);

  // 6. Stop the server.
  await t.closeChromium();
  await t.stopServer(server);
}

await t.run(main);
