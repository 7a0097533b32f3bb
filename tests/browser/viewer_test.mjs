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
// 4. Compares the screenshots over the pixels that show terrain in all three:
//    the normal-mapped low-poly tiles must be at least 3 times closer to the
//    high-res meshes than the bare low-poly tiles are, by the mean absolute
//    difference of luma (0..255). RMSE is printed too; it weighs the few pixels
//    on sunlit/shaded ridge crests that parallax shifts by a pixel (the low-poly
//    surface is not at the high-res height) far more than the shading itself.
// 5. Keeps the screenshots and difference images in <out>/ and stops the server
//    with SIGTERM.
//
// Exit code: 0 passed, 1 failed, 77 skipped (no Chromium or no playwright-core;
// `cd tests && npm ci` installs the latter). CHROMIUM=<path> picks another browser.
import { writeFile } from 'node:fs/promises';
import path from 'node:path';

import { createBrowserTest, decodePng, encodePngRgb, kRepo } from './browser_test_support.mjs';

// Limits. The whole test takes about 30 s on the 2-core development machine.
const kTileTimeoutMs = 180_000;
const kServeStartTimeoutMs = 30_000;
const kServeStopTimeoutMs = 10_000;
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
const kLowPolyTrianglesPerTile = 2 * 16 * 16;     // low_poly.grid 17
const kHighResTrianglesPerTile = 2 * 256 * 256;   // tile_size 256
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

async function main() {
  const { terrabake, out, tilesDir } = await t.setUp('viewer_test.mjs');

  // 1. A small layer.
  await t.tile(terrabake, ['--config', path.join(kRepo, 'config/sample.yaml'), '--zoom', kView.z,
    '--high-res-mesh', 'true', '--out', tilesDir, '--layer', kView.layer], kTileTimeoutMs);

  // 2. The server.
  let server;
  try {
    server = await t.startServer(terrabake, tilesDir, kServeStartTimeoutMs);
  } catch (error) {
    await t.abort(error.message);
  }
  log(`server at ${server.url}`);

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

  // 4. One camera and sun, three kinds of mesh.
  const images = {};
  const rows = [];
  for (const mode of kModes) {
    const query = new URLSearchParams({ ...kView, mode, wireframe: '0' });
    const url = `${server.url}?${query}`;
    const { page, stats, ms, ok } = await openViewer(url, `mode=${mode}`);
    const file = path.join(out, `viewer_${mode}.png`);
    try {
      const png = await page.locator('#view canvas').screenshot({ path: file, timeout: 30_000 });
      images[mode] = decodePng(png);
    } catch (error) {
      fail(`mode=${mode}: screenshot: ${error.message}`);
    }
    await t.closePage(page);
    rows.push({ mode, stats, ms, file });
    if (!ok || !stats) continue;
    const expectedTiles = Number(kView.maxTiles);
    const perTile = mode === 'highres' ? kHighResTrianglesPerTile : kLowPolyTrianglesPerTile;
    if (stats.tiles !== expectedTiles) fail(`mode=${mode}: ${stats.tiles} tiles shown, expected ${expectedTiles}`);
    if (stats.triangles !== stats.tiles * perTile) {
      fail(`mode=${mode}: ${stats.triangles} triangles for ${stats.tiles} tiles, expected ${perTile} a tile`);
    }
  }
  log(`view: ${new URLSearchParams(kView)}`);
  console.log('');
  console.log('  mode        tiles   triangles   load+draw   screenshot');
  for (const { mode, stats, ms, file } of rows) {
    console.log(`  ${mode.padEnd(10)} ${String(stats?.tiles ?? '-').padStart(6)} ${String(stats?.triangles ?? '-').padStart(11)} ${`${(ms / 1000).toFixed(1)} s`.padStart(11)}   ${file}`);
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

  // 6. Stop the server.
  await t.closeChromium();
  await t.stopServer(server, kServeStopTimeoutMs);
}

await t.run(main);
