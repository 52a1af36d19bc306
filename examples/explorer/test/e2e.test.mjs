// End-to-end tests of the explorer: `cadinterp explore` serves the built page, headless
// Chromium runs it (the asset evaluated by the WebAssembly runtime in the page), and what the
// page shows is compared with the native runtime (`cadinterp eval`) at the same x, and with
// the analytic bracket's geometry where it is known in closed form.
//
//   CADINTERP_CLI=build/.../cadinterp node --test examples/explorer/test/
// (scripts/test-explorer.sh sets everything up.)
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { join } from 'node:path';
import { after, before, describe, it } from 'node:test';
import {
  WORK, buildAsset, cli, dragSlider, nativeEval, nativeFeasible, openExplorer,
} from './harness.mjs';

const SHOTS = process.env.EXPLORER_SCREENSHOT_DIR || join(WORK, 'screenshots');
mkdirSync(SHOTS, { recursive: true });

function maxAbsDiff(a, b) {
  assert.equal(a.length, b.length);
  let m = 0;
  for (let i = 0; i < a.length; ++i) m = Math.max(m, Math.abs(a[i] - b[i]));
  return m;
}

function assertClose(actual, expected, rel, what) {
  const tol = rel * Math.max(1, Math.abs(expected));
  assert.ok(Math.abs(actual - expected) <= tol, `${what}: page ${actual}, native ${expected} (tolerance ${tol})`);
}

/** The page's drawn surface against the native mesh at the page's evaluated x. */
async function compareWithNative(page, asset, opts = {}) {
  // The properties come from the worker after the mesh: wait until they answer this shape.
  const st = await page.evaluate(() => window.__explorer.settled());
  if (!st.infeasible) assert.equal(st.worker, true, 'mass properties should come from the worker');
  if (!opts.allowInfeasible) assert.equal(st.infeasible, false, `the page reports infeasible: ${st.message}`);
  const surf = await page.evaluate(() => window.__explorer.surface());
  const nat = nativeEval(asset, st.evaluatedX, opts);
  const r = st.readout;
  assert.equal(r.vertices, nat.json.vertices, 'vertex count');
  assert.equal(r.tets, nat.json.tets, 'tet count');
  assert.equal(r.triangles, nat.json.triangles, 'triangle count');
  assert.equal(surf.triangles, nat.json.triangles, 'drawn triangles');
  assert.equal(r.element, nat.json.element, 'element');
  // Positions: float32 from two builds of the same kernel (wasm SIMD vs native AVX2 may order
  // the sums differently): a few ulps of the coordinates' size.
  let scale = 0;
  for (const v of nat.positions) scale = Math.max(scale, Math.abs(v));
  let worst = 0;
  surf.vertexIds.forEach((id, k) => {
    for (let c = 0; c < 3; ++c) worst = Math.max(worst, Math.abs(surf.positions[3 * k + c] - nat.positions[3 * id + c]));
  });
  assert.ok(worst <= 1e-6 * scale, `surface positions differ from native by ${worst} (scale ${scale})`);
  // Properties are double sums over float32 positions that may differ by an ulp or two
  // between the builds: relative 1e-6 (float32 epsilon is 6e-8).
  const p = nat.json.properties;
  assertClose(r.volume, p.volume, 1e-6, 'volume');
  assertClose(r.mass, p.mass, 1e-6, 'mass');
  assertClose(r.area, p.area, 1e-6, 'surface area');
  assertClose(r.frontalArea, p.frontal_area, 1e-6, 'frontal area');
  const axes = 'xyz';
  const Imax = Math.max(...r.inertia.map(Math.abs));
  for (let a = 0; a < 3; ++a)
    for (let b = 0; b < 3; ++b) {
      const v = p[`inertia_${axes[a]}${axes[b]}`];
      assert.ok(Math.abs(r.inertia[3 * a + b] - v) <= 1e-6 * Imax, `inertia ${axes[a]}${axes[b]}: ${r.inertia[3 * a + b]} vs ${v}`);
    }
  for (let c = 0; c < 3; ++c) assertClose(r.centroid[c], p[`centroid_${axes[c]}`], 1e-6, `centroid ${c}`);
  if (st.stressField) {
    const f = nat.json.fields.find((q) => q.name === st.stressField);
    const comps = f.components;
    let m = -Infinity;
    const vals = nat.fields[st.stressField];
    for (let i = 0; i < vals.length; i += comps) {
      let s = 0;
      for (let k = 0; k < comps; ++k) s += vals[i + k] ** 2;
      m = Math.max(m, comps === 1 ? vals[i] : Math.sqrt(s));
    }
    assertClose(r.maxStress, m, 1e-6, `max ${st.stressField}`);
  }
  if (nat.json.error_estimate === null) assert.ok(r.errorEstimate < 0, 'error estimate should be "not measured"');
  else assertClose(r.errorEstimate, nat.json.error_estimate, 1e-12, 'error estimate');
  return { st, surf, nat };
}

/** The largest angle (rad) between a unit vector turning through `span` and the direction of
 *  the linear interpolant of its two end values. */
function interpolationLag(span) {
  let lag = 0;
  for (let i = 0; i <= 1000; ++i) {
    const s = i / 1000;
    lag = Math.max(lag, Math.abs(Math.atan2(s * Math.sin(span), 1 - s + s * Math.cos(span)) - s * span));
  }
  return lag;
}

describe('explorer on the analytic bracket (with an infeasible corner)', () => {
  let asset, explorer, page, problems, params;

  before(async () => {
    asset = buildAsset('bracket_fail', 'bracket', 'cells=4,fail_region=1', ['--max-samples', '150']);
    params = JSON.parse(cli(['inspect', asset, '--json']).stdout).parameters;
    explorer = await openExplorer(asset);
    ({ page, problems } = explorer);
  });

  after(async () => {
    if (explorer) assert.equal(await explorer.close(), 0, 'cadinterp explore should exit 0 on SIGINT');
  });

  it('shows one slider per parameter with the asset\'s names, units and ranges, and every field', async () => {
    const sliders = await page.$$eval('.slider', (els) =>
      els.map((el) => ({
        label: el.querySelector('.name').textContent,
        min: +el.querySelector('input').min,
        max: +el.querySelector('input').max,
      })),
    );
    assert.deepEqual(
      sliders,
      params.map((p) => ({ label: p.unit ? `${p.name} [${p.unit}]` : p.name, min: p.lower, max: p.upper })),
    );
    const fields = JSON.parse(cli(['inspect', asset, '--json']).stdout).fields.map((f) => f.name);
    const options = await page.$$eval('#field-select option', (os) => os.map((o) => o.value).filter(Boolean));
    assert.deepEqual(options, fields);
    await page.screenshot({ path: join(SHOTS, 'bracket-initial.png') });
  });

  it('starts at the box centre (or the nearest feasible point) and matches native there', async () => {
    const st = await page.evaluate(() => window.__explorer.state());
    const centre = params.map((p) => 0.5 * (p.lower + p.upper));
    if (nativeFeasible(asset, centre)) assert.deepEqual(st.evaluatedX, centre);
    else assert.equal(nativeFeasible(asset, st.evaluatedX), true);
    st.evaluatedX.forEach((v, i) => assert.ok(v >= params[i].lower && v <= params[i].upper));
    await compareWithNative(page, asset);
  });

  it('follows a mouse drag of each slider: the mesh and the readouts change and match native', async () => {
    for (let i = 0; i < params.length; ++i) {
      const before = await page.evaluate(() => ({ st: window.__explorer.state(), surf: window.__explorer.surface() }));
      await dragSlider(page, i, i % 2 ? 0.8 : 0.2);
      await page.waitForFunction((k) => {
        const s = window.__explorer.state();
        return s.evaluatedX && s.evaluatedX[k] === s.x[k];
      }, i);
      const { st, surf } = await compareWithNative(page, asset);
      assert.notEqual(st.evaluatedX[i], before.st.evaluatedX[i], `slider ${i} did not move x`);
      st.evaluatedX.forEach((v, j) => j !== i && assert.equal(v, before.st.evaluatedX[j], `slider ${i} moved x[${j}]`));
      assert.ok(maxAbsDiff(surf.positions, before.surf.positions) > 1e-3, `slider ${i}: the mesh did not change`);
      assert.notEqual(st.readout.volume, before.st.readout.volume, `slider ${i}: volume unchanged`);
      assert.notEqual(st.readout.area, before.st.readout.area, `slider ${i}: area unchanged`);
      const shown = await page.$eval(`input[data-index="${i}"]`, (el) => el.closest('.slider').querySelector('.value').textContent);
      assert.ok(Math.abs(Number(shown) - st.x[i]) <= 1e-4 * Math.abs(st.x[i]), `slider ${i} shows ${shown}, x is ${st.x[i]}`);
    }
    await page.screenshot({ path: join(SHOTS, 'bracket-dragged.png') });
  });

  it('marks the infeasible ranges on the slider tracks where the native runtime refuses', async () => {
    const hp = params[1];
    await page.evaluate((h) => window.__explorer.setParam(1, h), hp.lower + 0.9 * (hp.upper - hp.lower));
    const st = await page.evaluate(() => window.__explorer.state());
    const runs = st.marks[0];
    assert.ok(runs.length > 0, 'with height in its top quarter, part of the length range must be infeasible');
    const drawn = await page.locator('.slider').nth(0).locator('.mark').count();
    assert.equal(drawn, runs.length, 'each infeasible run is drawn on the track');
    const lp = params[0];
    const step = (lp.upper - lp.lower) / 160;
    for (const [a, b] of runs) {
      const q = st.x.slice();
      q[0] = 0.5 * (a + b);
      assert.equal(nativeFeasible(asset, q), false, `length ${q[0]} is marked infeasible but native evaluates it`);
    }
    // Points at least a sample step away from every run are feasible natively.
    for (let k = 0; k <= 20; ++k) {
      const q = st.x.slice();
      q[0] = lp.lower + (k / 20) * (lp.upper - lp.lower);
      if (runs.some(([a, b]) => q[0] >= a - step && q[0] <= b + step)) continue;
      assert.equal(nativeFeasible(asset, q), true, `length ${q[0]} is not marked but native refuses it`);
    }
  });

  it('never evaluates an infeasible design: keeps the last feasible shape and says why', async () => {
    const st0 = await page.evaluate(() => window.__explorer.state());
    const [a, b] = st0.marks[0][st0.marks[0].length - 1];
    const lp = params[0];
    const frac = (v) => (v - lp.lower) / (lp.upper - lp.lower);
    // Into the run with the mouse: the drag passes feasible lengths on its way, then stops.
    await dragSlider(page, 0, frac(a + 0.3 * (b - a)));
    await page.waitForFunction(() => window.__explorer.state().infeasible);
    const bad = await page.evaluate(() => ({ st: window.__explorer.state(), surf: window.__explorer.surface() }));
    assert.ok(bad.st.x[0] >= a && bad.st.x[0] <= b, `the drag should end in the run [${a}, ${b}]: ${bad.st.x[0]}`);
    assert.equal(nativeFeasible(asset, bad.st.x), false);
    // What is on screen is a feasible design, the native mesh there.
    assert.notDeepEqual(bad.st.evaluatedX, bad.st.x);
    assert.equal(nativeFeasible(asset, bad.st.evaluatedX), true);
    await compareWithNative(page, asset, { allowInfeasible: true });
    const message = await page.locator('#message');
    assert.equal(await message.isVisible(), true);
    assert.match(await message.textContent(), /infeasible.*fail_region=1.*last feasible design/s);
    assert.equal(await page.locator('#readouts.stale').count(), 1, 'stale readouts are marked');
    await page.screenshot({ path: join(SHOTS, 'bracket-infeasible.png') });
    // Further inside the run: still nothing evaluated.
    await dragSlider(page, 0, frac(a + 0.7 * (b - a)));
    await page.waitForFunction((v) => window.__explorer.state().x[0] !== v, bad.st.x[0]);
    const worse = await page.evaluate(() => ({ st: window.__explorer.state(), surf: window.__explorer.surface() }));
    assert.equal(worse.st.infeasible, true);
    assert.deepEqual(worse.st.evaluatedX, bad.st.evaluatedX, 'the shape on screen must stay the last feasible one');
    assert.deepEqual(worse.surf.positions, bad.surf.positions);
    // Back to the centre of the feasible part: evaluated again, the message gone.
    await dragSlider(page, 0, frac(lp.lower + 0.5 * (a - lp.lower)));
    await page.waitForFunction(() => !window.__explorer.state().infeasible);
    assert.equal(await message.isVisible(), false);
    assert.equal(await page.locator('#readouts.stale').count(), 0);
    await compareWithNative(page, asset);
  });

  it('colours by every field, with the colour range of the native field values', async () => {
    const fields = await page.evaluate(() => window.__explorer.fields);
    for (const f of fields) {
      await page.evaluate((name) => window.__explorer.setField(name), f.name);
      const st = await page.evaluate(() => window.__explorer.state());
      const surf = await page.evaluate(() => window.__explorer.surface());
      const nat = nativeEval(asset, st.evaluatedX);
      const vals = nat.fields[f.name];
      let lo = Infinity, hi = -Infinity;
      for (let i = 0; i < vals.length; i += f.components) {
        let s = 0;
        for (let k = 0; k < f.components; ++k) s += vals[i + k] ** 2;
        const v = f.components === 1 ? vals[i] : Math.sqrt(s);
        lo = Math.min(lo, v);
        hi = Math.max(hi, v);
      }
      assertClose(st.colorRange[0], lo, 1e-6, `${f.name} min`);
      assertClose(st.colorRange[1], hi, 1e-6, `${f.name} max`);
      const distinct = new Set();
      for (let i = 0; i < surf.colors.length; i += 3) distinct.add(surf.colors.slice(i, i + 3).join());
      assert.ok(distinct.size > 5, `${f.name}: the surface should show several colours, got ${distinct.size}`);
      const ticks = await page.$$eval('#legend-ticks span', (s) => s.map((e) => Number(e.textContent)));
      assert.equal(ticks.length, 5);
      assertClose(ticks[0], lo, 1e-3, `${f.name} legend bottom`);
      assertClose(ticks[4], hi, 1e-3, `${f.name} legend top`);
      await page.screenshot({ path: join(SHOTS, `bracket-field-${f.name}.png`) });
    }
  });

  it('scales mass and inertia with the density input', async () => {
    const rho = 7.85e-6; // steel, kg/mm^3
    await page.evaluate((d) => window.__explorer.setDensity(d), rho);
    await compareWithNative(page, asset, { density: rho });
    const r = (await page.evaluate(() => window.__explorer.state())).readout;
    assertClose(r.mass, rho * r.volume, 1e-12, 'mass = density * volume');
    await page.evaluate(() => window.__explorer.setDensity(1));
  });

  it('draws the fixed face hatched and the load as an arrow along the leg end\'s inward normal', async () => {
    for (const angle of [60, 90, 130]) {
      const st = await page.evaluate((a) => window.__explorer.setParam(3, a), angle);
      assert.equal(st.infeasible, false);
      assert.ok(st.overlayTriangles > 0, 'the fixed region is drawn');
      assert.equal(st.arrows.length, 1);
      const arrow = st.arrows[0];
      assert.equal(arrow.visible, true);
      // The leg leaves the bend along (cos a, sin a, 0); its end face (the load region) has that
      // outward normal, so the arrow points along minus it.
      const t = (angle * Math.PI) / 180;
      const expected = [-Math.cos(t), -Math.sin(t), 0];
      // 90 degrees is a start-grid sample at the other parameters' defaults, where the
      // interpolant is the host. Between samples the linear interpolant of the rotating load
      // lags the rotation: across a start-grid element (45 degrees of bend, which the 150-sample
      // budget may leave unsplit beside the infeasible corner's splits) by up to 8.0e-3 rad.
      const tol = angle === 90 ? 2e-3 : interpolationLag(Math.PI / 4) + 2e-3;
      for (let c = 0; c < 3; ++c)
        assert.ok(Math.abs(arrow.direction[c] - expected[c]) < tol, `bend ${angle}: arrow ${arrow.direction} vs ${expected} (tolerance ${tol})`);
    }
    await page.screenshot({ path: join(SHOTS, 'bracket-bend-130.png') });
  });

  it('raised no page or console errors', () => {
    assert.deepEqual(problems, []);
  });
});

describe('explorer on the analytic plate (a vector field; mesh resolution that follows size)', () => {
  let asset, varying, explorer, page, problems;

  before(async () => {
    // Plate cells are round(size / edge): with edge = 100 mm one cell everywhere (fixed
    // combinatorics); with edge = 10 mm the vertex count changes across the box, which only a
    // build with the mesh mapper (src/mapping) can precompute.
    try {
      asset = buildAsset('plate_varying', 'plate', 'edge=10', ['--max-samples', '60']);
      varying = true;
    } catch (e) {
      if (!/combinatorics/.test(e.message)) throw e;
      asset = buildAsset('plate', 'plate', 'edge=100', ['--max-samples', '60']);
      varying = false;
    }
    explorer = await openExplorer(asset);
    ({ page, problems } = explorer);
  });

  after(async () => {
    if (explorer) assert.equal(await explorer.close(), 0);
  });

  it('follows the length slider and matches native (topology changes when the build has a mapper)', async (t) => {
    const counts = new Set();
    for (const u of [0.05, 0.5, 0.95]) {
      await dragSlider(page, 0, u);
      await page.waitForFunction(() => {
        const s = window.__explorer.state();
        return s.evaluatedX && s.evaluatedX[0] === s.x[0];
      });
      const { st } = await compareWithNative(page, asset);
      counts.add(st.readout.vertices);
    }
    if (varying) assert.ok(counts.size >= 2, `the plate's vertex count should change along length: ${[...counts]}`);
    else t.diagnostic('fixed-combinatorics plate: this cadinterp has no mesh mapper, so the topology-change path is not exercised');
    await page.screenshot({ path: join(SHOTS, 'plate.png') });
  });

  it('shows the displacement vector field by magnitude', async () => {
    await page.evaluate(() => window.__explorer.setField('displacement'));
    const st = await page.evaluate(() => window.__explorer.state());
    const nat = nativeEval(asset, st.evaluatedX);
    const d = nat.fields.displacement;
    let lo = Infinity, hi = 0;
    for (let i = 0; i < d.length; i += 3) {
      const m = Math.hypot(d[i], d[i + 1], d[i + 2]);
      lo = Math.min(lo, m);
      hi = Math.max(hi, m);
    }
    assertClose(st.colorRange[0], lo, 1e-6, '|displacement| min');
    assertClose(st.colorRange[1], hi, 1e-6, '|displacement| max');
    await page.screenshot({ path: join(SHOTS, 'plate-displacement.png') });
  });

  it('points the load arrow at the x = length face along -x', async () => {
    const st = await page.evaluate(() => window.__explorer.state());
    const arrow = st.arrows[0];
    assert.equal(arrow.visible, true);
    assert.ok(Math.abs(arrow.direction[0] + 1) < 1e-6, `arrow direction ${arrow.direction}`);
  });

  it('raised no page or console errors', () => {
    assert.deepEqual(problems, []);
  });
});
