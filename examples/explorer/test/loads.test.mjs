// End-to-end tests of the explorer's force arrows and field units in headless Chromium:
//  - the OpenCASCADE wrench (examples/hosts/occt) with only load_angle varying: the host emits
//    the applied traction as a field, and the page draws the handle-end arrow along its mean
//    over the region. Checked against the native runtime (`cadinterp eval` at the page's x) and
//    against the load the host defines, F (0, -cos a, sin a) spread over the 14 x 6 mm end face.
//  - field units (format 1.1): the legend, the field selector and the max-stress readout show
//    what `cadinterp inspect` reads from the asset.
// The wrench needs the OCCT host library: EXPLORER_OCCT_HOST names it (scripts/test-explorer.sh
// builds it when the build has the OCCT component); without it those tests are skipped.
import assert from 'node:assert/strict';
import { existsSync, mkdirSync } from 'node:fs';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { after, before, describe, it } from 'node:test';
import { WORK, cli, dragSlider, nativeEval, openExplorer, openPage, startServer } from './harness.mjs';

const SHOTS = process.env.EXPLORER_SCREENSHOT_DIR || join(WORK, 'screenshots');
mkdirSync(SHOTS, { recursive: true });
const REPO = resolve(dirname(fileURLToPath(import.meta.url)), '../../..');
const OCCT_HOST = process.env.EXPLORER_OCCT_HOST || '';
const haveOcct = OCCT_HOST !== '' && existsSync(OCCT_HOST);

// The wrench's load (examples/hosts/occt/occt_models.cpp): 200 N on the handle's end face
// (14 mm wide, 6 mm thick), tilted out of the plane by load_angle.
const FORCE = 200;
const END_FACE_AREA = 14 * 6;

const norm = (v) => Math.hypot(...v);
const unit = (v) => v.map((c) => c / norm(v));

/** Field units as the native tool reads them from the asset. */
function nativeUnits(asset) {
  const info = JSON.parse(cli(['inspect', asset, '--json']).stdout);
  return Object.fromEntries(info.fields.map((f) => [f.name, f.unit]));
}

/** Waits until the page has evaluated at the x its sliders show. */
async function evaluated(page) {
  await page.waitForFunction(() => {
    const s = window.__explorer.state();
    return s.evaluatedX && s.evaluatedX.every((v, i) => v === s.x[i]);
  });
  return page.evaluate(() => window.__explorer.settled());
}

describe('explorer on the OCCT wrench with a varying load angle (arrows follow the load)', { skip: haveOcct ? false : 'EXPLORER_OCCT_HOST not set (a build without the OCCT host)' }, () => {
  let asset, explorer, page, problems;

  before(async () => {
    asset = join(WORK, 'wrench_load_angle.cadi');
    if (!existsSync(asset)) {
      // Coarse mesh, one parameter, a handful of samples: a few seconds on 2 cores.
      cli(['build', '--host', OCCT_HOST, '--model', 'wrench', '--host-options', 'mesh_size=8,order=1,vary=load_angle',
        '--max-samples', '5', '--threads', '2', '-q', '-o', asset]);
    }
    explorer = await openExplorer(asset);
    ({ page, problems } = explorer);
  });

  after(async () => {
    if (explorer) assert.equal(await explorer.close(), 0);
  });

  it('has a traction field in MPa-consistent units and one force region', async () => {
    const fields = await page.evaluate(() => window.__explorer.fields);
    const t = fields.find((f) => f.name === 'traction');
    assert.ok(t, `the wrench asset should carry the host's traction field: ${fields.map((f) => f.name)}`);
    assert.equal(t.components, 3);
    assert.equal(t.location, 'vertex');
    const st = await page.evaluate(() => window.__explorer.state());
    assert.deepEqual(st.arrows.map((a) => a.region), ['handle_end']);
    assert.equal(st.arrows[0].source, 'traction');
  });

  it('turns the arrow with the load_angle slider, as native and as the host defines', async () => {
    const dirs = [];
    for (const u of [0.05, 0.5, 0.95]) {
      await dragSlider(page, 0, u);
      const st = await evaluated(page);
      assert.equal(st.infeasible, false, st.message);
      const angle = st.evaluatedX[0]; // degrees
      const arrow = st.arrows[0];
      assert.equal(arrow.visible, true);
      assert.equal(arrow.source, 'traction');

      // Native truth at the same x: the traction the native runtime interpolates. The host puts
      // F / A on every vertex of the end face in every sample, so the native field is uniform on
      // the loaded vertices and its mean there is the region's area-weighted mean.
      const nat = nativeEval(asset, st.evaluatedX);
      const tv = nat.fields.traction;
      const loaded = [];
      for (let i = 0; i < tv.length; i += 3) if (Math.hypot(tv[i], tv[i + 1], tv[i + 2]) > 0) loaded.push([tv[i], tv[i + 1], tv[i + 2]]);
      assert.ok(loaded.length >= 4, `native traction is zero almost everywhere (${loaded.length} loaded vertices)`);
      const mean = [0, 1, 2].map((c) => loaded.reduce((s, v) => s + v[c], 0) / loaded.length);
      const spread = Math.max(...loaded.map((v) => norm(v.map((c, i) => c - mean[i]))));
      assert.ok(spread <= 1e-4 * norm(mean), `native traction not uniform on the end face: spread ${spread}, mean ${mean}`);
      for (let c = 0; c < 3; ++c) {
        assert.ok(Math.abs(arrow.traction[c] - mean[c]) <= 1e-5 * norm(mean), `mean traction ${arrow.traction} vs native ${mean}`);
      }
      const d = unit(mean);
      for (let c = 0; c < 3; ++c) assert.ok(Math.abs(arrow.direction[c] - d[c]) < 1e-5, `arrow ${arrow.direction} vs native ${d}`);

      // The host's definition: F (0, -cos a, sin a) / A. Interpolating vectors between samples
      // shortens them a little between samples (a chord, not an arc): 2 % on magnitude, 0.01 on
      // the unit direction.
      const a = (angle * Math.PI) / 180;
      const host = [0, -Math.cos(a), Math.sin(a)];
      for (let c = 0; c < 3; ++c) assert.ok(Math.abs(arrow.direction[c] - host[c]) < 0.01, `arrow ${arrow.direction} vs host ${host} at ${angle} deg`);
      const want = FORCE / END_FACE_AREA;
      assert.ok(Math.abs(arrow.magnitude - want) <= 0.02 * want, `|traction| ${arrow.magnitude}, host F/A ${want}`);
      // The tip touches the end face's centroid (x = -handle length is the far end: the
      // arrow starts outside the part and points along the load).
      const tip = arrow.position.map((p, c) => p + arrow.length * arrow.direction[c]);
      assert.ok(Math.abs(tip[0] - Math.min(...nat.positions.filter((_, i) => i % 3 === 0))) < 1e-3, `tip ${tip}`);
      assert.match(arrow.label, /load [\d.]+/);
      dirs.push({ angle, dir: arrow.direction });
      await page.screenshot({ path: join(SHOTS, `wrench-load-${Math.round(angle)}.png`) });
    }
    // It rotates: the drawn directions differ by the angles the slider moved through.
    const turned = (Math.acos(dirs[0].dir.reduce((s, c, i) => s + c * dirs[2].dir[i], 0)) * 180) / Math.PI;
    const moved = dirs[2].angle - dirs[0].angle;
    assert.ok(moved > 40, `the slider should span most of [-30, 30] deg: ${moved}`);
    assert.ok(Math.abs(turned - moved) < 1, `the arrow turned ${turned} deg while the load angle moved ${moved} deg`);
  });

  it('shows the units native reads from the asset (legend, selector, max stress)', async (t) => {
    const units = nativeUnits(asset);
    const fields = await page.evaluate(() => window.__explorer.fields);
    for (const f of fields) assert.equal(f.unit, units[f.name], `unit of ${f.name}`);
    const st = await page.evaluate(() => window.__explorer.setField('von_mises'));
    if (units.von_mises) {
      assert.equal(st.legendTitle, `von_mises in ${units.von_mises}`);
      assert.equal(units.von_mises, 'MPa', 'the OCCT models are in mm and N: stress in MPa');
      assert.equal(units.traction, 'MPa');
      assert.equal(units.displacement, 'mm');
    } else {
      // The host sets units (cadinterp_sample_set_field_unit); a builder that does not copy
      // them into the asset yields none, and the page must say so rather than invent one.
      assert.equal(st.legendTitle, 'von_mises (no unit in the asset)');
      t.diagnostic('this build wrote the wrench asset without field units');
    }
  });

  it('raised no page or console errors', () => {
    assert.deepEqual(problems, []);
  });
});

describe('explorer field units on a format 1.1 asset (conformance k1_units)', () => {
  const asset = join(REPO, 'conformance/cases/valid/k1_units/asset.cadi');
  let explorer, page, problems;

  before(async () => {
    explorer = await openExplorer(asset);
    ({ page, problems } = explorer);
  });

  after(async () => {
    if (explorer) assert.equal(await explorer.close(), 0);
  });

  it('shows each field\'s unit in the legend, the selector and the readouts', async () => {
    const units = nativeUnits(asset);
    assert.deepEqual(units, { temperature: 'K', stress: 'MPa' });
    let st = await page.evaluate(() => window.__explorer.setField('temperature'));
    assert.equal(st.legendTitle, 'temperature in K');
    st = await page.evaluate(() => window.__explorer.setField('stress'));
    assert.equal(st.legendTitle, 'stress in MPa');
    const options = await page.$$eval('#field-select option', (os) => os.map((o) => o.textContent));
    assert.ok(options.includes('temperature [K] (per vertex)'), `${options}`);
    assert.ok(options.includes('stress [MPa] (per tet)'), `${options}`);
    const rows = await page.$$eval('#readouts tr', (rs) => rs.map((r) => [r.cells[0].textContent, r.cells[1].textContent]));
    const maxStress = rows.find(([k]) => k === 'max stress');
    assert.ok(maxStress && / MPa$/.test(maxStress[1]), `max stress readout: ${maxStress}`);
    // The legend's values are the field's range at this x, as native computes it.
    const nat = nativeEval(asset, st.evaluatedX);
    const f = nat.json.fields.find((q) => q.name === 'stress');
    assert.ok(Math.abs(st.colorRange[0] - f.min) <= 1e-6 * Math.max(1, Math.abs(f.min)));
    assert.ok(Math.abs(st.colorRange[1] - f.max) <= 1e-6 * Math.max(1, Math.abs(f.max)));
    await page.screenshot({ path: join(SHOTS, 'units-k1.png') });
  });

  it('says so when a field has no unit (format 1.0 asset)', async () => {
    const old = join(REPO, 'conformance/cases/valid/k1_linear/asset.cadi');
    const s2 = await startServer(old);
    try {
      const { page: p2, problems: pr2 } = await openPage(explorer.browser.context, s2.url);
      const st = await p2.evaluate(() => window.__explorer.setField('temperature'));
      assert.equal(st.legendTitle, 'temperature (no unit in the asset)');
      assert.deepEqual(pr2, []);
      await p2.close();
    } finally {
      assert.equal(await s2.stop(), 0);
    }
  });

  it('raised no page or console errors', () => {
    assert.deepEqual(problems, []);
  });
});
