// The Optimize panel end to end: `cadinterp explore` runs Ipopt on the served asset (POST
// api/optimize) and the page, in headless Chromium, moves its sliders along the iterates to x*.
//
// The asset: the analytic plate with one cell per axis (edge=100), a box L x W x T whose vertex
// positions are multilinear in (L, W, T), so its interpolant is exact: volume = L W T and
// area = 2 (L W + L T + W T) everywhere. Minimizing the area subject to volume >= 25000 with
// T fixed at 10 has the minimizer L = W = 50 (the square base of that volume).
import assert from 'node:assert/strict';
import { createReadStream, existsSync, mkdirSync, statSync } from 'node:fs';
import { createServer } from 'node:http';
import { dirname, extname, join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { after, before, describe, it } from 'node:test';
import { CLI, WORK, buildAsset, launchBrowser, openExplorer, openPage } from './harness.mjs';

const ROOT = fileURLToPath(new URL('../../..', import.meta.url));
const WASM = process.env.EXPLORER_WASM_DIR || join(ROOT, 'build/wasm');
const WEB = join(dirname(CLI), '../../examples/explorer/web');
const X_STAR = [50, 50, 10];
const SHOTS = process.env.EXPLORER_SCREENSHOT_DIR || join(WORK, 'screenshots');
mkdirSync(SHOTS, { recursive: true });

async function setInputs(page, { objective, constraints = '', fix = [] }) {
  await page.fill('#opt-objective', objective);
  await page.fill('#opt-constraints', constraints);
  const boxes = page.locator('#opt-fixed input[type=checkbox]');
  for (let i = 0; i < (await boxes.count()); ++i) await boxes.nth(i).setChecked(fix.includes(i));
}

/** Clicks "optimize" and resolves, once the run is over, with the slider positions seen. */
async function runFromPage(page) {
  await page.evaluate(() => {
    window.__seen = [];
    window.__watch = setInterval(() => window.__seen.push(window.__explorer.state().x.join(',')), 20);
  });
  await page.click('#opt-run');
  await page.waitForFunction(() => {
    const s = window.__explorer.optimizer();
    return !s.running && (s.result || s.error);
  }, null, { timeout: 60000 });
  return page.evaluate(() => {
    clearInterval(window.__watch);
    return [...new Set(window.__seen)];
  });
}

describe('the Optimize panel with `cadinterp explore`', () => {
  let explorer, page, problems;

  before(async () => {
    const asset = buildAsset('plate_box', 'plate', 'edge=100', ['--max-samples', '30']);
    explorer = await openExplorer(asset);
    ({ page, problems } = explorer);
    await page.waitForFunction(() => window.__explorer.optimizer().available !== null);
  });

  after(async () => {
    if (explorer) assert.equal(await explorer.close(), 0);
  });

  it('lists the asset\'s quantities and a fix box per parameter', async () => {
    const s = await page.evaluate(() => window.__explorer.optimizer());
    assert.equal(s.available, true, s.unavailableMessage);
    const options = await page.$$eval('#opt-quantities option', (os) => os.map((o) => o.value));
    for (const q of ['volume', 'area', 'integral(von_mises)', 'max(temperature)', 'region_area(fixed)'])
      assert.ok(options.includes(q), `${q} not among ${options.join(', ')}`);
    assert.equal(await page.locator('#opt-fixed input[type=checkbox]').count(), 3);
  });

  it('runs Ipopt on the server, animates the sliders along the iterates to x*, shows the optimum', async () => {
    await page.evaluate(() => window.__explorer.setX([70, 40, 10]));
    await setInputs(page, { objective: 'area', constraints: 'volume >= 25000', fix: [2] });
    const seen = await runFromPage(page);
    const s = await page.evaluate(() => window.__explorer.optimizer());
    assert.equal(s.error, null, JSON.stringify(s.error));
    const r = s.result.result;
    assert.match(r.status, /optimal|acceptable/);
    assert.ok(r.path.length >= 3, `a path of ${r.path.length} iterates`);
    assert.ok(seen.length >= 3, `the sliders passed ${seen.length} positions: ${seen.join(' | ')}`);
    // The sliders end exactly at the server's x*, which is the known minimizer.
    const st = await page.evaluate(() => window.__explorer.settled());
    const xs = s.result.parameters.map((n) => r.x[n]);
    assert.deepEqual(st.x, xs);
    const sliders = await page.$$eval('input[type=range]', (els) => els.map((e) => Number(e.value)));
    st.x.forEach((v, i) => {
      assert.ok(Math.abs(v - X_STAR[i]) <= 0.01, `x*[${i}] = ${v}, expected ${X_STAR[i]}`);
      assert.ok(Math.abs(sliders[i] - v) <= 1e-9 * Math.abs(v), `slider ${i} at ${sliders[i]}, x* ${v}`);
    });
    // The readouts are the optimum's: the page's own (WebAssembly) properties and the panel's.
    assert.ok(Math.abs(st.readout.area - 7000) <= 1e-3 * 7000, `area ${st.readout.area}`);
    assert.ok(Math.abs(st.readout.volume - 25000) <= 1e-3 * 25000, `volume ${st.readout.volume}`);
    assert.ok(Math.abs(r.objective - st.readout.area) <= 1e-5 * 7000, `${r.objective} vs ${st.readout.area}`);
    const table = await page.$$eval('#opt-result tr', (rows) => Object.fromEntries(rows.map((t) => [t.cells[0].textContent, t.cells[1].textContent])));
    assert.ok(Math.abs(Number(table['minimize area']) - 7000) <= 0.01, JSON.stringify(table));
    assert.ok(Math.abs(Number(table['volume >= 25000']) - 25000) <= 0.05, JSON.stringify(table));
    assert.ok(Math.abs(Number(table['x* length']) - 50) <= 0.01, JSON.stringify(table));
    assert.match(table['error estimate at x*'], /% of bbox diagonal|not measured/);
    assert.match(await page.textContent('#opt-status'), /done: the sliders are at x\*/);
    await page.screenshot({ path: join(SHOTS, 'optimize-done.png') });
    assert.deepEqual(problems, []);
  });

  it('shows the server\'s message and the offending token for a bad expression', async () => {
    await setInputs(page, { objective: 'area + 2*volum', constraints: 'volume >= 1' });
    await runFromPage(page);
    const s = await page.evaluate(() => window.__explorer.optimizer());
    assert.equal(s.error.status, 400);
    assert.equal(s.error.input, 'objective');
    const shown = await page.textContent('#opt-error');
    assert.match(shown, /objective: column 10: unknown quantity 'volum'/);
    assert.match(shown, /area \+ 2\*volum\n {9}\^/);
    assert.equal(await page.locator('#opt-error').isVisible(), true);
    // A constraint naming a field the asset lacks: which constraint, and the token.
    await setInputs(page, { objective: 'area', constraints: 'volume >= 1\nintegral(stress) <= 1' });
    await runFromPage(page);
    assert.match(await page.textContent('#opt-error'), /constraint 2: column 10: the asset has no field 'stress'/);
  });
});

describe('the Optimize panel on a static host', () => {
  let server, browser;

  before(async () => {
    const asset = buildAsset('plate_box', 'plate', 'edge=100', ['--max-samples', '30']);
    // Only files: the page, the runtime under wasm/ and the asset; no api/ at all.
    const types = { '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript', '.css': 'text/css', '.wasm': 'application/wasm' };
    server = createServer((req, res) => {
      const path = new URL(req.url, 'http://x').pathname;
      let file = path === '/asset.cadi' ? asset : path.startsWith('/wasm/') ? join(WASM, path.slice(6)) : join(WEB, path === '/' ? 'index.html' : path);
      if (!existsSync(file) || !statSync(file).isFile()) {
        res.writeHead(404).end('not found');
        return;
      }
      res.writeHead(200, { 'content-type': types[extname(file)] ?? 'application/octet-stream' });
      createReadStream(file).pipe(res);
    });
    await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
    browser = await launchBrowser();
  });

  after(async () => {
    await browser?.close();
    server?.close();
  });

  it('says that optimization needs `cadinterp explore`', async () => {
    const url = `http://127.0.0.1:${server.address().port}/?asset=asset.cadi&wasm=wasm`;
    const { page } = await openPage(browser.context, url);
    await page.waitForFunction(() => window.__explorer.optimizer().available !== null);
    const s = await page.evaluate(() => window.__explorer.optimizer());
    assert.equal(s.available, false);
    assert.match(s.unavailableMessage, /needs `cadinterp explore`/);
    assert.equal(await page.locator('#opt-unavailable').isVisible(), true);
    assert.equal(await page.locator('#opt-run').isVisible(), false);
  });
});

