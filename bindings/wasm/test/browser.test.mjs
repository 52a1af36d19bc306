// The module in a real browser: headless Chromium loads cadinterp.mjs from a local HTTP server
// with the default loader (fetch + WebAssembly.instantiateStreaming of cadinterp_wasm.wasm),
// opens a conformance asset fetched over HTTP, on the page and in a module Web Worker, and posts
// the results back to the server; they are compared here with the native outputs of the case.
// Skipped when no Chromium is installed (CHROMIUM overrides the binary).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { readFile } from 'node:fs/promises';
import { spawn } from 'node:child_process';
import { repoRoot, wasmDir, parseExpected, assertClose } from '../test-support/helpers.mjs';

const chromium = process.env.CHROMIUM ?? ['/usr/bin/chromium', '/usr/bin/chromium-browser', '/usr/bin/google-chrome']
  .find((p) => existsSync(p));

// Both the page and the worker report to POST /result/<who>.
const report = `async function report(who, value) {
  await fetch('/result/' + who, { method: 'POST', body: JSON.stringify(value) });
}`;

const page = `<!doctype html><html><body><script type="module">
import { load, CadinterpError } from '/wasm/cadinterp.mjs';
${report}
const x = JSON.parse(new URLSearchParams(location.search).get('x'));
const bytes = await (await fetch('/cases/valid/k2_cubic/asset.cadi')).arrayBuffer();
const w = new Worker('/worker.mjs', { type: 'module' });
w.onerror = (ev) => report('worker', { error: 'worker: ' + ev.message });
w.postMessage({ bytes: bytes.slice(0), x });
try {
  const lib = await load();
  const a = lib.open(bytes);
  const m = a.eval(x, ['temperature'], { copy: true });
  const g = a.grad(x, ['temperature'], { copy: true });
  let outside = null;
  try { a.eval([2, 2]); } catch (e) { outside = [e instanceof CadinterpError, e.statusName]; }
  let truncated = null;
  try { lib.open(new Uint8Array(bytes).slice(0, 20)); } catch (e) { truncated = e.statusName; }
  a.close();
  await report('page', { version: lib.version, element: m.element, positions: Array.from(m.positions),
    temperature: Array.from(m.fields.temperature), dpositions: Array.from(g.dpositions), outside, truncated });
} catch (e) {
  await report('page', { error: String(e && e.stack || e) });
}
</script></body></html>`;

const workerSource = `import { load } from '/wasm/cadinterp.mjs';
${report}
self.onmessage = async (ev) => {
  try {
    const lib = await load();
    const a = lib.open(ev.data.bytes);
    const m = a.eval(ev.data.x, [], { copy: true });
    a.close();
    await report('worker', { positions: Array.from(m.positions) });
  } catch (e) {
    await report('worker', { error: String(e && e.stack || e) });
  }
};`;

const types = { '.mjs': 'text/javascript', '.wasm': 'application/wasm' };

test('loads and evaluates in headless Chromium, on the page and in a worker',
  { skip: chromium ? false : 'no Chromium installed', timeout: 120000 }, async () => {
    const results = {};
    const waiters = {};
    const arrived = (who) => new Promise((resolve) => { waiters[who] = resolve; });
    const got = { page: arrived('page'), worker: arrived('worker') };
    const server = http.createServer(async (req, res) => {
      const u = decodeURIComponent(new URL(req.url, 'http://localhost').pathname);
      if (req.method === 'POST' && u.startsWith('/result/')) {
        let body = '';
        for await (const chunk of req) body += chunk;
        const who = u.slice('/result/'.length);
        results[who] = JSON.parse(body);
        waiters[who]?.();
        res.writeHead(204);
        res.end();
        return;
      }
      if (u === '/page.html' || u === '/worker.mjs') {
        res.writeHead(200, { 'content-type': u === '/page.html' ? 'text/html' : 'text/javascript' });
        res.end(u === '/page.html' ? page : workerSource);
        return;
      }
      let file = null;
      if (u.startsWith('/wasm/')) file = path.join(wasmDir, path.basename(u));
      else if (u.startsWith('/cases/')) file = path.join(repoRoot, 'conformance', path.normalize(u));
      try {
        const body = await readFile(file);
        res.writeHead(200, { 'content-type': types[path.extname(file)] ?? 'application/octet-stream' });
        res.end(body);
      } catch {
        res.writeHead(404);
        res.end();
      }
    });
    await new Promise((r) => server.listen(0, '127.0.0.1', r));
    const profile = mkdtempSync(path.join(os.tmpdir(), 'cadinterp-chromium-'));
    const exp = parseExpected('valid', 'k2_cubic');
    const p = exp.points.find((q) => q.status === 'CADINTERP_OK');
    const url = `http://127.0.0.1:${server.address().port}/page.html?x=${encodeURIComponent(JSON.stringify(p.x))}`;
    // The flags after --no-first-run keep Chromium from reaching out to a network that is closed
    // here. Its own process group, so that the kill below reaches the renderer and utility
    // processes too: they keep writing into the profile after the browser process is gone.
    const browser = spawn(chromium, ['--headless=new', '--no-sandbox', '--disable-gpu', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync', '--disable-quic',
      '--disable-extensions', `--user-data-dir=${profile}`, url], { stdio: 'ignore', detached: true });
    let timer;
    try {
      const exited = new Promise((_, reject) => browser.on('exit', (c) => reject(new Error(`chromium exited (${c})`))));
      const timeout = new Promise((_, reject) => { timer = setTimeout(() => reject(new Error('no result in 90 s')), 90000); });
      await Promise.race([Promise.all([got.page, got.worker]), exited, timeout]);
    } finally {
      clearTimeout(timer);
      const gone = new Promise((r) => (browser.exitCode !== null || browser.signalCode !== null ? r() : browser.once('exit', r)));
      try { process.kill(-browser.pid, 'SIGTERM'); } catch { /* the group has already exited */ }
      await gone;
      server.close();
      // A child that outlives the group's signal by a moment can still be closing its files.
      rmSync(profile, { recursive: true, force: true, maxRetries: 10, retryDelay: 100 });
    }
    const r = results.page;
    assert.equal(r.error, undefined, r.error);
    assert.equal(r.version, '1.0.0');
    assert.equal(r.element, p.element);
    assertClose(r.positions, p.positions, exp.tolerance, 'positions');
    assertClose(r.temperature, p.field0, exp.tolerance, 'temperature');
    p.dpositions.forEach((want, d) => assertClose(r.dpositions.slice(d * want.length), want, exp.gradTolerance, `dpositions[${d}]`));
    assert.deepEqual(r.outside, [true, 'CADINTERP_E_OUTSIDE_DOMAIN']);
    assert.equal(r.truncated, 'CADINTERP_E_TRUNCATED');
    assert.equal(results.worker.error, undefined, results.worker.error);
    assertClose(results.worker.positions, p.positions, exp.tolerance, 'positions in a worker');
  });
