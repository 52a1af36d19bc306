// Shared by the end-to-end tests and the frame-rate measurement: starts `cadinterp explore`,
// launches Debian's headless Chromium through playwright-core, and asks the native runtime
// (`cadinterp eval`) for the truth the page is compared against.
import { spawn, spawnSync } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';

export const CLI = process.env.CADINTERP_CLI;
export const WORK = process.env.EXPLORER_WORK_DIR || mkdtempSync(join(tmpdir(), 'explorer-'));
if (!CLI) throw new Error('set CADINTERP_CLI to the cadinterp executable (scripts/test-explorer.sh does)');

/** Runs the cadinterp tool; returns { status, stdout, stderr }. */
export function cli(args, { check = true } = {}) {
  const r = spawnSync(CLI, args, { encoding: 'utf8', maxBuffer: 1 << 30 });
  if (check && r.status !== 0) throw new Error(`cadinterp ${args.join(' ')} failed (${r.status}): ${r.stderr}`);
  return r;
}

/** Builds an asset with the analytic host unless it exists. */
export function buildAsset(name, model, hostOptions, extra = []) {
  const out = join(WORK, `${name}.cadi`);
  try {
    readFileSync(out, { flag: 'r' });
    return out;
  } catch {
    /* not built yet */
  }
  cli(['build', '--host', 'analytic', '--model', model, '--host-options', hostOptions, '--threads', '2', '-q', '-o', out, ...extra]);
  return out;
}

/** Starts `cadinterp explore ASSET --port 0`; resolves with { url, stop() } once it serves. */
export function startServer(asset, extraArgs = []) {
  return new Promise((resolve, reject) => {
    const wasm = process.env.EXPLORER_WASM_DIR ? ['--wasm-dir', process.env.EXPLORER_WASM_DIR] : [];
    const p = spawn(CLI, ['explore', asset, '--port', '0', ...wasm, ...extraArgs], { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '', err = '';
    const timer = setTimeout(() => reject(new Error(`cadinterp explore printed no URL in 60 s: ${out} ${err}`)), 60000);
    p.stderr.on('data', (d) => (err += d));
    p.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/(http:\/\/127\.0\.0\.1:\d+\/)/);
      if (m) {
        clearTimeout(timer);
        resolve({
          url: m[1],
          log: () => out + err,
          stop: () =>
            new Promise((done) => {
              if (p.exitCode !== null) return done(p.exitCode);
              p.once('exit', (code) => done(code));
              p.kill('SIGINT');
            }),
        });
      }
    });
    p.once('exit', (code) => {
      clearTimeout(timer);
      reject(new Error(`cadinterp explore exited with ${code}: ${err}`));
    });
  });
}

/** Headless Chromium (Debian's /usr/bin/chromium) with a fresh profile. */
export async function launchBrowser() {
  const profile = mkdtempSync(join(tmpdir(), 'explorer-chromium-'));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    viewport: { width: 1280, height: 800 },
    args: [
      '--headless',
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      // WebGL without a GPU: SwiftShader, which Chromium no longer falls back to by itself.
      '--enable-unsafe-swiftshader',
    ],
  });
  const close = async () => {
    await context.close();
    rmSync(profile, { recursive: true, force: true, maxRetries: 10, retryDelay: 100 });
  };
  return { context, close };
}

/** Opens the page and waits for the explorer to be ready; page errors fail the caller. */
export async function openPage(context, url) {
  const page = await context.newPage();
  const problems = [];
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('console', (m) => {
    if (m.type() === 'error') problems.push(`console error: ${m.text()}`);
  });
  await page.goto(url);
  await page.waitForFunction(() => window.__explorer?.ready || window.__explorer?.error, null, { timeout: 60000 });
  const error = await page.evaluate(() => window.__explorer.error);
  if (error) throw new Error(`the explorer failed to start: ${error}`);
  return { page, problems };
}

/**
 * `cadinterp explore ASSET` with the page open on it in a fresh headless Chromium. close() shuts
 * the browser and the server and returns the server's exit status (0 on SIGINT).
 */
export async function openExplorer(asset, extraArgs = []) {
  const server = await startServer(asset, extraArgs);
  let browser;
  try {
    browser = await launchBrowser();
    const { page, problems } = await openPage(browser.context, server.url);
    const close = async () => {
      await browser.close();
      return server.stop();
    };
    return { server, browser, page, problems, close };
  } catch (e) {
    await browser?.close();
    await server.stop();
    throw e;
  }
}

/** Numbers of a named ASCII VTU DataArray. */
function vtuArray(text, name) {
  const re = new RegExp(`<DataArray[^>]*Name="${name}"[^>]*>([^<]*)</DataArray>`);
  const m = text.match(re);
  if (!m) throw new Error(`VTU has no DataArray ${name}`);
  return m[1].trim().split(/\s+/).map(Number);
}

/**
 * The native runtime's answer at x: `cadinterp eval --json` (properties, field ranges, element,
 * error estimate) and the full mesh from an ASCII VTU export (positions and every field, printed
 * with 9 significant digits: float32 round trip).
 */
export function nativeEval(asset, x, { density = 1, direction = '1,0,0' } = {}) {
  const vtu = join(WORK, `native-${process.pid}.vtu`);
  const r = cli([
    'eval', asset, ...x.map((v) => String(v)), '--json', '--fields', 'all', '--density', String(density),
    '--direction', direction, '--vtu', vtu, '--ascii',
  ]);
  const json = JSON.parse(r.stdout);
  const text = readFileSync(vtu, 'utf8');
  const fields = {};
  for (const f of json.fields) fields[f.name] = vtuArray(text, f.name);
  return { json, positions: vtuArray(text, 'Points'), fields };
}

/** Whether the native runtime can evaluate at x (exit 0) or says infeasible. */
export function nativeFeasible(asset, x) {
  const r = cli(['eval', asset, ...x.map(String), '--fields', ''], { check: false });
  if (r.status === 0) return true;
  if (r.stderr.includes('CADINTERP_E_INFEASIBLE')) return false;
  throw new Error(`cadinterp eval at ${x}: ${r.stderr}`);
}

/** Drags slider i's thumb with the mouse from its position to fraction u of the track. */
export async function dragSlider(page, i, u, steps = 12) {
  const input = page.locator(`input[type=range][data-index="${i}"]`);
  const box = await input.boundingBox();
  const { value, min, max } = await input.evaluate((el) => ({ value: +el.value, min: +el.min, max: +el.max }));
  // Chromium's range thumb (16 px wide here) travels between half a thumb from either end.
  const thumb = 16;
  const at = (f) => box.x + thumb / 2 + f * (box.width - thumb);
  const y = box.y + box.height / 2;
  await page.mouse.move(at((value - min) / (max - min)), y);
  await page.mouse.down();
  await page.mouse.move(at(u), y, { steps });
  await page.mouse.up();
}
