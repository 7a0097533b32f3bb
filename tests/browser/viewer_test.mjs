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
import { spawn } from 'node:child_process';
import { existsSync } from 'node:fs';
import { mkdir, mkdtemp, rm, writeFile } from 'node:fs/promises';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import zlib from 'node:zlib';

const kRepo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const kChromium = process.env.CHROMIUM || '/usr/bin/chromium';
const kSkip = 77;

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

const failures = [];
function fail(message) {
  failures.push(message);
  console.error(`viewer_test: FAIL: ${message}`);
}
function log(message) {
  console.log(`viewer_test: ${message}`);
}

// ---------------------------------------------------------------------------
// Processes

const children = new Set();
let browserContext = null;
let profileDir = null;

function runToEnd(command, args, timeoutMs) {
  return new Promise((resolve) => {
    const child = spawn(command, args, { stdio: ['ignore', 'pipe', 'pipe'] });
    children.add(child);
    let output = '';
    child.stdout.on('data', (d) => { output += d; });
    child.stderr.on('data', (d) => { output += d; });
    const timer = setTimeout(() => child.kill('SIGKILL'), timeoutMs);
    child.on('error', (error) => { output += `${error.message}\n`; });
    child.on('close', (code, signal) => {
      clearTimeout(timer);
      children.delete(child);
      resolve({ code, signal, output });
    });
  });
}

// Starts `terrabake serve` and resolves to {child, url} once it prints its line.
function startServer(terrabake, tilesDir) {
  return new Promise((resolve, reject) => {
    const child = spawn(terrabake, ['serve', '--tiles', tilesDir, '--port', '0'], { stdio: ['ignore', 'pipe', 'pipe'] });
    children.add(child);
    let stdout = '';
    let stderr = '';
    let settled = false;
    const settle = (fn, value) => {
      if (settled) return;
      settled = true;
      clearTimeout(timer);
      fn(value);
    };
    const timer = setTimeout(() => settle(reject, new Error(
      `terrabake serve printed no 'serving ... on http://127.0.0.1:<port>/' line within ${kServeStartTimeoutMs / 1000} s; stdout: ${JSON.stringify(stdout)} stderr: ${JSON.stringify(stderr)}`)), kServeStartTimeoutMs);
    child.stdout.on('data', (d) => {
      stdout += d;
      const match = stdout.match(/^terrabake: serving .+ on (http:\/\/127\.0\.0\.1:(\d+)\/)\r?$/m);
      if (match && Number(match[2]) > 0) settle(resolve, { child, url: match[1] });
    });
    child.stderr.on('data', (d) => { stderr += d; });
    child.on('error', (error) => settle(reject, new Error(`cannot start terrabake serve: ${error.message}`)));
    child.on('exit', (code, signal) => {
      children.delete(child);
      settle(reject, new Error(`terrabake serve exited (code ${code}, signal ${signal}) before announcing its port: ${stderr.trim() || stdout.trim()}`));
    });
  });
}

// SIGTERM, then waits for the exit; SIGKILL if it does not come. Resolves to
// a description of how it ended.
function stopProcess(child, timeoutMs) {
  return new Promise((resolve) => {
    if (child.exitCode !== null || child.signalCode !== null) {
      resolve({ code: child.exitCode, signal: child.signalCode, already: true });
      return;
    }
    const timer = setTimeout(() => {
      child.kill('SIGKILL');
      resolve({ code: null, signal: 'SIGKILL', timedOut: true });
    }, timeoutMs);
    child.once('exit', (code, signal) => {
      clearTimeout(timer);
      children.delete(child);
      resolve({ code, signal });
    });
    child.kill('SIGTERM');
  });
}

let cleanedUp = false;
async function cleanup() {
  if (cleanedUp) return;
  cleanedUp = true;
  if (browserContext) {
    await Promise.race([browserContext.close().catch(() => {}), new Promise((r) => setTimeout(r, 10_000))]);
    browserContext = null;
  }
  for (const child of children) child.kill('SIGKILL');
  if (profileDir) await rm(profileDir, { recursive: true, force: true }).catch(() => {});
}

async function abort(message, code = 1) {
  console.error(`viewer_test: ${code === kSkip ? 'SKIP' : 'FAIL'}: ${message}`);
  await cleanup();
  process.exit(code);
}

const watchdog = setTimeout(() => abort(`did not finish within ${kWatchdogMs / 1000} s`), kWatchdogMs);
for (const signal of ['SIGINT', 'SIGTERM']) {
  process.on(signal, () => abort(`interrupted by ${signal}`));
}

// ---------------------------------------------------------------------------
// PNG (8-bit RGB/RGBA, not interlaced: what Chromium writes) and image metrics

function crc32(bytes) {
  let crc = ~0;
  for (const byte of bytes) {
    crc ^= byte;
    for (let k = 0; k < 8; ++k) crc = (crc >>> 1) ^ (0xedb88320 & -(crc & 1));
  }
  return ~crc >>> 0;
}

function decodePng(buffer) {
  if (buffer.readUInt32BE(0) !== 0x89504e47) throw new Error('not a PNG');
  let offset = 8;
  let width = 0;
  let height = 0;
  let channels = 0;
  const idat = [];
  while (offset < buffer.length) {
    const length = buffer.readUInt32BE(offset);
    const type = buffer.toString('latin1', offset + 4, offset + 8);
    const data = buffer.subarray(offset + 8, offset + 8 + length);
    if (type === 'IHDR') {
      width = data.readUInt32BE(0);
      height = data.readUInt32BE(4);
      const [depth, colour, , , interlace] = data.subarray(8);
      channels = { 2: 3, 6: 4 }[colour];
      if (depth !== 8 || !channels || interlace !== 0) {
        throw new Error(`unsupported PNG: depth ${depth}, colour type ${colour}, interlace ${interlace}`);
      }
    } else if (type === 'IDAT') {
      idat.push(data);
    }
    offset += 12 + length;
  }
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  const pixels = Buffer.alloc(height * stride);
  for (let y = 0; y < height; ++y) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    const out = y * stride;
    for (let i = 0; i < stride; ++i) {
      const a = i >= channels ? pixels[out + i - channels] : 0;
      const b = y > 0 ? pixels[out - stride + i] : 0;
      const c = i >= channels && y > 0 ? pixels[out - stride + i - channels] : 0;
      let predictor;
      switch (filter) {
        case 0: predictor = 0; break;
        case 1: predictor = a; break;
        case 2: predictor = b; break;
        case 3: predictor = (a + b) >> 1; break;
        case 4: {
          const p = a + b - c;
          const pa = Math.abs(p - a);
          const pb = Math.abs(p - b);
          const pc = Math.abs(p - c);
          predictor = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
          break;
        }
        default: throw new Error(`bad PNG filter ${filter}`);
      }
      pixels[out + i] = (line[i] + predictor) & 0xff;
    }
  }
  // Always hand back RGB.
  const rgb = Buffer.alloc(width * height * 3);
  for (let p = 0; p < width * height; ++p) pixels.copy(rgb, p * 3, p * channels, p * channels + 3);
  return { width, height, rgb };
}

function encodePngRgb(width, height, rgb) {
  const raw = Buffer.alloc(height * (width * 3 + 1));
  for (let y = 0; y < height; ++y) rgb.copy(raw, y * (width * 3 + 1) + 1, y * width * 3, (y + 1) * width * 3);
  const chunk = (type, data) => {
    const body = Buffer.concat([Buffer.from(type, 'latin1'), data]);
    const head = Buffer.alloc(4);
    head.writeUInt32BE(data.length);
    const tail = Buffer.alloc(4);
    tail.writeUInt32BE(crc32(body));
    return Buffer.concat([head, body, tail]);
  };
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0);
  ihdr.writeUInt32BE(height, 4);
  ihdr.set([8, 2, 0, 0, 0], 8);
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
    chunk('IHDR', ihdr), chunk('IDAT', zlib.deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]);
}

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

// Opens url in a new page; fails the test on console errors, page errors,
// failed requests and HTTP errors; resolves to {page, stats, ms}.
async function openViewer(url, name) {
  const page = await browserContext.newPage();
  const problems = [];
  page.on('console', (message) => {
    if (message.type() === 'error') problems.push(`console error: ${message.text()}`);
  });
  page.on('pageerror', (error) => problems.push(`page error: ${error.message}`));
  page.on('requestfailed', (request) => problems.push(`request failed: ${request.url()} (${request.failure()?.errorText})`));
  page.on('response', (response) => {
    if (response.status() >= 400) problems.push(`HTTP ${response.status()}: ${response.url()}`);
  });
  const started = Date.now();
  let stats = null;
  try {
    await page.goto(url, { waitUntil: 'load', timeout: kPageTimeoutMs });
    await page.waitForFunction(() => window.terrabakeReady === true, null, { timeout: kPageTimeoutMs, polling: 100 });
    stats = await page.evaluate(() => window.terrabakeStats);
  } catch (error) {
    const status = await page.locator('#status').textContent({ timeout: 1000 }).catch(() => '');
    problems.push(`not ready: ${error.message.split('\n')[0]}${status ? ` (viewer status: ${status})` : ''}`);
  }
  for (const problem of problems) fail(`${name}: ${problem}`);
  return { page, stats, ms: Date.now() - started, ok: problems.length === 0 };
}

// ---------------------------------------------------------------------------

async function main() {
  const [terrabakeArg, outArg] = process.argv.slice(2);
  if (!terrabakeArg || !outArg) {
    await abort('usage: node tests/browser/viewer_test.mjs <terrabake executable> <output folder>', 2);
  }
  const terrabake = path.resolve(terrabakeArg);
  const out = path.resolve(outArg);

  let chromium;
  try {
    ({ chromium } = await import('playwright-core'));
  } catch (error) {
    await abort(`playwright-core is not installed (cd tests && npm ci): ${error.message}`, kSkip);
  }
  if (!existsSync(kChromium)) await abort(`no Chromium at ${kChromium} (set CHROMIUM=<path>)`, kSkip);
  if (!existsSync(terrabake)) await abort(`no terrabake executable at ${terrabake}`);

  // 1. A small layer.
  const tilesDir = path.join(out, 'tiles');
  await rm(tilesDir, { recursive: true, force: true });
  await mkdir(out, { recursive: true });
  const tileArgs = ['tile', '--config', path.join(kRepo, 'config/sample.yaml'), '--zoom', kView.z,
    '--high-res-mesh', 'true', '--out', tilesDir, '--layer', kView.layer];
  log(`${terrabake} ${tileArgs.join(' ')}`);
  const tiled = await runToEnd(terrabake, tileArgs, kTileTimeoutMs);
  if (tiled.code !== 0) await abort(`terrabake tile ended with code ${tiled.code} (signal ${tiled.signal}):\n${tiled.output}`);

  // 2. The server.
  let server;
  try {
    server = await startServer(terrabake, tilesDir);
  } catch (error) {
    await abort(error.message);
  }
  log(`server at ${server.url}`);

  // 3. The browser, with a fresh profile and nothing from the network.
  profileDir = await mkdtemp(path.join(os.tmpdir(), 'terrabake-chromium-'));
  try {
    browserContext = await chromium.launchPersistentContext(profileDir, {
      executablePath: kChromium,
      headless: true,
      // Room for the panel (220 px) beside the fixed-size canvas.
      viewport: { width: Number(kView.width) + 280, height: Math.max(700, Number(kView.height) + 40) },
      deviceScaleFactor: 1,
      timeout: 60_000,
      args: ['--headless=new', '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader',
        '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--disable-quic', '--no-first-run',
        '--disable-background-networking', '--disable-component-update', '--disable-sync',
        '--disable-extensions', '--disable-default-apps', '--no-default-browser-check'],
    });
  } catch (error) {
    await abort(`cannot start Chromium (${kChromium}): ${error.message}`);
  }

  // As a user opens it: default layer and zoom, canvas filling the window.
  {
    const { page, stats, ms } = await openViewer(server.url, 'viewer (no parameters)');
    const file = path.join(out, 'viewer_default.png');
    await page.screenshot({ path: file }).catch((error) => fail(`screenshot ${file}: ${error.message}`));
    log(`viewer (no parameters): ${stats ? `${stats.tiles} tiles, ${stats.triangles} triangles` : 'not ready'}, ${ms} ms -> ${file}`);
    if (stats && !(stats.tiles > 0 && stats.triangles > 0)) fail(`viewer (no parameters) shows nothing: ${JSON.stringify(stats)}`);
    await page.close();
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
    await page.close();
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
  await browserContext.close().catch((error) => fail(`closing Chromium: ${error.message}`));
  browserContext = null;
  const stopped = await stopProcess(server.child, kServeStopTimeoutMs);
  if (stopped.timedOut) {
    fail(`terrabake serve did not exit within ${kServeStopTimeoutMs / 1000} s of SIGTERM (killed)`);
  } else if (stopped.already) {
    fail(`terrabake serve had already exited (code ${stopped.code}, signal ${stopped.signal}) before SIGTERM`);
  } else {
    log(`server stopped by SIGTERM (exit code ${stopped.code}, signal ${stopped.signal})`);
  }
}

try {
  await main();
} catch (error) {
  fail(`unexpected: ${error.stack || error}`);
}
await cleanup();
clearTimeout(watchdog);
if (failures.length) {
  console.error(`viewer_test: ${failures.length} failure(s)`);
  process.exit(1);
}
log('passed');
process.exit(0);
