// The conformance cases (conformance/cases, written by cadinterp-make-conformance from the
// native runtime) against the WebAssembly build: every invalid case fails with the expected
// status name, every valid case evaluates to the native outputs within the case's tolerances.
// Mirrors conformance/runner.cpp: eval and grad with field 0 when the asset has fields.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { library, caseBytes, caseNames, parseExpected, assertClose } from '../test-support/helpers.mjs';

const { api, lib } = await library();

function runCase(group, name) {
  const exp = parseExpected(group, name);
  assert.ok(exp.open, 'expected.txt has an open line');
  let asset;
  try {
    asset = lib.open(caseBytes(group, name));
  } catch (e) {
    assert.ok(e instanceof api.CadinterpError, `open threw ${e}`);
    assert.equal(e.statusName, exp.open, `open: ${e.message}`);
    assert.equal(api.STATUS_NAMES[e.status], e.statusName);
    assert.ok(e.message.length > 0 && e.message !== e.statusName, 'the C ABI message comes along');
    if (exp.openMessage) assert.ok(e.message.includes(exp.openMessage), `open message: ${e.message}`);
    return { opened: false, points: 0 };
  }
  try {
    assert.equal('CADINTERP_OK', exp.open, 'open succeeded where the case expects a failure');
    const fields = asset.fields.length > 0 ? [asset.fields[0].name] : [];
    for (const [i, unit] of Object.entries(exp.units)) assert.equal(asset.fields[Number(i)].unit, unit, `field ${i} unit`);
    for (const p of exp.points) {
      assert.equal(p.x.length, asset.dim);
      let mesh;
      try {
        mesh = asset.eval(p.x, fields, { copy: true });
      } catch (e) {
        assert.ok(e instanceof api.CadinterpError, `eval threw ${e}`);
        assert.equal(e.statusName, p.status, `eval at ${p.x}: ${e.message}`);
        // grad fails alike (the runner checks eval only; the ABI documents both).
        assert.throws(() => asset.grad(p.x, fields), (g) => g.statusName === p.status);
        continue;
      }
      assert.equal('CADINTERP_OK', p.status, `eval at ${p.x} succeeded, expected ${p.status}`);
      const g = asset.grad(p.x, fields);
      if (p.element !== undefined) assert.equal(mesh.element, p.element);
      if (p.positions) {
        assert.equal(p.positions.length, 3 * mesh.vertexCount, 'vertex count');
        assertClose(mesh.positions, p.positions, exp.tolerance, 'positions');
        assertClose(g.positions, p.positions, exp.tolerance, 'grad positions');
      }
      p.dpositions.forEach((want, d) => {
        assertClose(g.dpositions.subarray(d * want.length), want, exp.gradTolerance, `dpositions[${d}]`);
      });
      if (p.field0) assertClose(mesh.fields[fields[0]], p.field0, exp.tolerance, 'field0');
      p.dfield0.forEach((want, d) => {
        assertClose(g.dfields[fields[0]].subarray(d * want.length), want, exp.gradTolerance, `dfield0[${d}]`);
      });
    }
    return { opened: true, points: exp.points.length };
  } finally {
    asset.close();
  }
}

const valid = caseNames('valid');
const invalid = caseNames('invalid');

test('the committed case list is the one this test knows about', () => {
  assert.ok(valid.length >= 7, `valid cases: ${valid}`);
  assert.ok(invalid.length >= 19, `invalid cases: ${invalid}`);
});

for (const name of valid) {
  test(`valid/${name}`, () => {
    const r = runCase('valid', name);
    assert.ok(r.opened);
    assert.ok(r.points > 0, 'the case evaluates at least one point');
  });
}

for (const name of invalid) {
  test(`invalid/${name}`, () => {
    runCase('invalid', name);
  });
}
