// No leaks: after a warm-up pass over a point sequence (which fills the element cache and the
// runtime's per-thread decode scratch), 1000 more calls leave the bytes allocated in the
// WebAssembly heap and the size of its memory unchanged; opening and closing assets returns the
// allocation count to its level. The counts come from malloc itself (mallinfo, wasm_glue.c).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { library, caseBytes, rng } from '../test-support/helpers.mjs';

const { api, lib } = await library();

function points(asset, n, seed) {
  const r = rng(seed);
  return Array.from({ length: n }, () => asset.parameters.map((p) => p.lower + r() * (p.upper - p.lower)));
}

test('1000 evaluations do not grow the heap', () => {
  const a = lib.open(caseBytes('valid', 'k3_cubic'));
  try {
    const xs = points(a, 250, 3);
    const fields = a.fields.map((f) => f.name);
    const pass = () => {
      for (const x of xs) {
        const m = a.eval(x, fields);
        const g = a.grad(x, fields);
        a.vjp(x, new Float32Array(3 * m.vertexCount).fill(1), { [fields[0]]: new Float32Array(m.vertexCount).fill(1) });
        a.properties(x, { grad: true });
        assert.equal(g.vertexCount, m.vertexCount);
      }
    };
    // Failing calls keep their message in the workspace (a string that grows to the longest).
    const errors = (n) => {
      for (let i = 0; i < n; ++i) {
        assert.throws(() => a.eval([2, 2, 2]), api.CadinterpError);
        assert.throws(() => a.grad([0.5, NaN, 0.5]), api.CadinterpError);
        assert.throws(() => a.eval(xs[0], ['missing']), api.CadinterpError);
      }
    };
    pass();
    errors(1);
    const before = lib.memoryStats();
    pass(); // 4 x 250 = 1000 calls
    errors(100);
    pass();
    const after = lib.memoryStats();
    assert.equal(after.mallocBytes, before.mallocBytes, 'bytes allocated in the heap');
    assert.equal(after.heapBytes, before.heapBytes, 'WebAssembly memory size');
  } finally {
    a.close();
  }
});

test('open and close return the heap to its level', () => {
  const bytes = caseBytes('valid', 'k4_linear');
  const cycle = () => {
    const a = lib.open(bytes);
    const x = a.parameters.map((p) => (p.lower + p.upper) / 2);
    a.eval(x);
    a.grad(x);
    a.close();
    assert.throws(() => lib.open(caseBytes('invalid', 'index_checksum')), api.CadinterpError);
  };
  cycle();
  const before = lib.memoryStats();
  for (let i = 0; i < 50; ++i) cycle();
  const after = lib.memoryStats();
  assert.equal(after.mallocBytes, before.mallocBytes);
  assert.equal(after.heapBytes, before.heapBytes);
  // The asset's bytes were in the heap while it was open.
  const a = lib.open(bytes);
  assert.ok(lib.memoryStats().mallocBytes >= before.mallocBytes + bytes.length);
  a.close();
  assert.equal(lib.memoryStats().mallocBytes, before.mallocBytes);
});
