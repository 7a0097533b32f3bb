// What the browser tests (viewer_test.mjs, three_shading_test.mjs) share:
// child processes with deadlines (`terrabake tile`, `terrabake serve`), headless
// Chromium with a fresh profile and nothing from the network, pages that fail
// the test on console errors, and an 8-bit PNG decoder and encoder.
//
//   const t = createBrowserTest('viewer_test', { watchdogMs: 540_000 });
//   await t.run(async () => { ... t.fail('...') ... });   // exits 0, 1 or 77
//
// Exit code of run(): 0 passed, 1 failed, 77 skipped (no Chromium or no
// playwright-core; `cd tests && npm ci` installs the latter). CHROMIUM=<path>
// picks another browser.
import { spawn } from 'node:child_process';
import { existsSync } from 'node:fs';
import { mkdir, mkdtemp, rm } from 'node:fs/promises';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import zlib from 'node:zlib';

export const kRepo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
export const kChromium = process.env.CHROMIUM || '/usr/bin/chromium';
export const kSkip = 77;

// SwiftShader WebGL on the CPU: the same pictures on every machine, no GPU needed.
const kChromiumArgs = ['--headless=new', '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
  '--disable-extensions', '--disable-default-apps', '--no-default-browser-check'];
const kChromiumStartTimeoutMs = 60_000;
const kBrowserCloseTimeoutMs = 10_000;
// terrabake serve announces its port within this, and exits this soon after SIGTERM.
const kServeStartTimeoutMs = 30_000;
const kServeStopTimeoutMs = 10_000;
const kScreenshotTimeoutMs = 30_000;

export function createBrowserTest(name, { watchdogMs }) {
  const failures = [];
  const children = new Set();
  let browserContext = null;
  let profileDir = null;
  let cleanedUp = false;
  const pageProblems = new WeakMap();  // page -> {label, list, reported}

  const log = (message) => console.log(`${name}: ${message}`);
  const fail = (message) => {
    failures.push(message);
    console.error(`${name}: FAIL: ${message}`);
  };

  async function cleanup() {
    if (cleanedUp) return;
    cleanedUp = true;
    if (browserContext) {
      await Promise.race([browserContext.close().catch(() => {}), new Promise((r) => setTimeout(r, kBrowserCloseTimeoutMs))]);
      browserContext = null;
    }
    for (const child of children) child.kill('SIGKILL');
    if (profileDir) await rm(profileDir, { recursive: true, force: true }).catch(() => {});
  }

  // Ends the test now: FAIL (code 1 and others) or SKIP (77).
  async function abort(message, code = 1) {
    console.error(`${name}: ${code === kSkip ? 'SKIP' : 'FAIL'}: ${message}`);
    await cleanup();
    process.exit(code);
  }

  // Runs a command to its end; SIGKILL after timeoutMs. Resolves to {code, signal, output}.
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

  // `terrabake tile <args>`; aborts the test unless it exits 0.
  async function tile(terrabake, args, timeoutMs) {
    log(`${terrabake} tile ${args.join(' ')}`);
    const tiled = await runToEnd(terrabake, ['tile', ...args], timeoutMs);
    if (tiled.code !== 0) await abort(`terrabake tile ended with code ${tiled.code} (signal ${tiled.signal}):\n${tiled.output}`);
    return tiled.output;
  }

  // Starts `terrabake serve --tiles <tilesDir> --port 0` and resolves to
  // {child, url} once it prints its line; rejects after timeoutMs.
  function startServer(terrabake, tilesDir, timeoutMs) {
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
        `terrabake serve printed no 'serving ... on http://127.0.0.1:<port>/' line within ${timeoutMs / 1000} s; stdout: ${JSON.stringify(stdout)} stderr: ${JSON.stringify(stderr)}`)), timeoutMs);
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

  // startServer, ending the test when the server does not start; logs its URL.
  async function serve(terrabake, tilesDir, timeoutMs = kServeStartTimeoutMs) {
    let server;
    try {
      server = await startServer(terrabake, tilesDir, timeoutMs);
    } catch (error) {
      await abort(error.message);
    }
    log(`server at ${server.url}`);
    return server;
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

  // Stops the server with SIGTERM; fails the test if it had already exited or
  // does not exit within timeoutMs.
  async function stopServer(server, timeoutMs = kServeStopTimeoutMs) {
    const stopped = await stopProcess(server.child, timeoutMs);
    if (stopped.timedOut) {
      fail(`terrabake serve did not exit within ${timeoutMs / 1000} s of SIGTERM (killed)`);
    } else if (stopped.already) {
      fail(`terrabake serve had already exited (code ${stopped.code}, signal ${stopped.signal}) before SIGTERM`);
    } else {
      log(`server stopped by SIGTERM (exit code ${stopped.code}, signal ${stopped.signal})`);
    }
  }

  // Skips the test without playwright-core or Chromium; call it before any
  // slow work. Resolves to playwright's chromium.
  let chromium = null;
  async function requireChromium() {
    if (chromium) return chromium;
    try {
      ({ chromium } = await import('playwright-core'));
    } catch (error) {
      await abort(`playwright-core is not installed (cd tests && npm ci): ${error.message}`, kSkip);
    }
    if (!existsSync(kChromium)) await abort(`no Chromium at ${kChromium} (set CHROMIUM=<path>)`, kSkip);
    return chromium;
  }

  // The command line every browser test takes, `<terrabake executable>
  // <output folder>`, checked (Chromium too); the output folder made and its
  // tiles/ emptied. Resolves to { terrabake, out, tilesDir }.
  async function setUp(script) {
    const [terrabakeArg, outArg] = process.argv.slice(2);
    if (!terrabakeArg || !outArg) {
      await abort(`usage: node tests/browser/${script} <terrabake executable> <output folder>`, 2);
    }
    const terrabake = path.resolve(terrabakeArg);
    const out = path.resolve(outArg);
    await requireChromium();
    if (!existsSync(terrabake)) await abort(`no terrabake executable at ${terrabake}`);
    const tilesDir = path.join(out, 'tiles');
    await rm(tilesDir, { recursive: true, force: true });
    await mkdir(out, { recursive: true });
    return { terrabake, out, tilesDir };
  }

  // Headless Chromium with a fresh profile (skips as requireChromium does).
  // Resolves to the browser context.
  async function launchChromium({ viewport }) {
    await requireChromium();
    profileDir = await mkdtemp(path.join(os.tmpdir(), 'terrabake-chromium-'));
    try {
      browserContext = await chromium.launchPersistentContext(profileDir, {
        executablePath: kChromium,
        headless: true,
        viewport,
        deviceScaleFactor: 1,
        timeout: kChromiumStartTimeoutMs,
        args: kChromiumArgs,
      });
    } catch (error) {
      await abort(`cannot start Chromium (${kChromium}): ${error.message}`);
    }
    return browserContext;
  }

  async function closeChromium() {
    if (!browserContext) return;
    await browserContext.close().catch((error) => fail(`closing Chromium: ${error.message}`));
    browserContext = null;
  }

  // Opens url in a new page and waits for window.terrabakeReady === true.
  // Console errors, page errors, failed requests and HTTP errors fail the test
  // (requests the page cancels itself too, unless cancelledRequestsAllowed):
  // those until the page is ready right away, later ones when the page is
  // closed with closePage(). notReadyDetail(page) may add to the message of a
  // page that never gets ready. Resolves to {page, ms, ok}.
  async function openPage(url, label, { timeoutMs, notReadyDetail, cancelledRequestsAllowed = false } = {}) {
    const page = await browserContext.newPage();
    const problems = [];
    page.on('console', (message) => {
      if (message.type() === 'error') problems.push(`console error: ${message.text()}`);
    });
    page.on('pageerror', (error) => problems.push(`page error: ${error.message}`));
    page.on('requestfailed', (request) => {
      const reason = request.failure()?.errorText;
      if (cancelledRequestsAllowed && reason === 'net::ERR_ABORTED') return;
      problems.push(`request failed: ${request.url()} (${reason})`);
    });
    page.on('response', (response) => {
      if (response.status() >= 400) problems.push(`HTTP ${response.status()}: ${response.url()}`);
    });
    const started = Date.now();
    try {
      await page.goto(url, { waitUntil: 'load', timeout: timeoutMs });
      await page.waitForFunction(() => window.terrabakeReady === true, null, { timeout: timeoutMs, polling: 100 });
    } catch (error) {
      const detail = notReadyDetail ? await notReadyDetail(page).catch(() => '') : '';
      problems.push(`not ready: ${error.message.split('\n')[0]}${detail ? ` (${detail})` : ''}`);
    }
    const ok = problems.length === 0;
    const reported = problems.length;
    for (const problem of problems) fail(`${label}: ${problem}`);
    pageProblems.set(page, { label, list: problems, reported });
    return { page, ms: Date.now() - started, ok };
  }

  async function closePage(page) {
    const problems = pageProblems.get(page);
    await page.close().catch(() => {});
    if (problems) for (const problem of problems.list.slice(problems.reported)) fail(`${problems.label}: ${problem}`);
  }

  // Opens url as openPage does and, once it is ready, saves a screenshot as
  // <out>/<name>.png and resolves to inspect({page, image, ms, file}), image
  // decoded; null when the page never got ready or inspecting it threw.
  async function screenshotPage(url, out, name, pageOptions, inspect) {
    const { page, ms, ok } = await openPage(url, name, pageOptions);
    let result = null;
    if (ok) {
      const file = path.join(out, `${name}.png`);
      try {
        const image = decodePng(await page.screenshot({ path: file, timeout: kScreenshotTimeoutMs }));
        result = await inspect({ page, image, ms, file });
      } catch (error) {
        fail(`${name}: ${error.message}`);
      }
    }
    await closePage(page);
    return result;
  }

  // Runs main with a watchdog and SIGINT/SIGTERM handling, cleans up, and
  // exits: 0 when nothing failed, else 1.
  async function run(main) {
    const watchdog = setTimeout(() => abort(`did not finish within ${watchdogMs / 1000} s`), watchdogMs);
    for (const signal of ['SIGINT', 'SIGTERM']) {
      process.on(signal, () => abort(`interrupted by ${signal}`));
    }
    try {
      await main();
    } catch (error) {
      fail(`unexpected: ${error.stack || error}`);
    }
    await cleanup();
    clearTimeout(watchdog);
    if (failures.length) {
      console.error(`${name}: ${failures.length} failure(s)`);
      process.exit(1);
    }
    log('passed');
    process.exit(0);
  }

  return {
    log, fail, abort, failures, runToEnd, tile, startServer, serve, stopProcess, stopServer,
    requireChromium, setUp, launchChromium, closeChromium, openPage, closePage, screenshotPage, run,
  };
}

// ---------------------------------------------------------------------------
// PNG (8-bit RGB/RGBA, not interlaced: what Chromium writes)

function crc32(bytes) {
  let crc = ~0;
  for (const byte of bytes) {
    crc ^= byte;
    for (let k = 0; k < 8; ++k) crc = (crc >>> 1) ^ (0xedb88320 & -(crc & 1));
  }
  return ~crc >>> 0;
}

// Decodes to {width, height, rgb}: always RGB, alpha dropped.
export function decodePng(buffer) {
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
  const rgb = Buffer.alloc(width * height * 3);
  for (let p = 0; p < width * height; ++p) pixels.copy(rgb, p * 3, p * channels, p * channels + 3);
  return { width, height, rgb };
}

// 8-bit RGB PNG of width x height pixels, rows from the top.
export function encodePngRgb(width, height, rgb) {
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
