// The JavaScript API against independent truths: derivatives against central finite
// differences of eval, vjp against the grad arrays, mass properties against sums over the
// evaluated tets and triangles computed here, errors against the C ABI's documented statuses.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { library, caseBytes, rng } from '../test-support/helpers.mjs';

const { api, lib } = await library();
const { CadinterpError } = api;

function throwsStatus(fn, statusName) {
  assert.throws(fn, (e) => {
    assert.ok(e instanceof CadinterpError, `not a CadinterpError: ${e}`);
    assert.ok(e instanceof Error);
    assert.equal(e.statusName, statusName, e.message);
    assert.equal(api.STATUS_NAMES[e.status], statusName);
    return true;
  });
}

// A point of the box away from its faces: lower + t (upper - lower).
const inner = (asset, t) => asset.parameters.map((p, d) => p.lower + t[d % t.length] * (p.upper - p.lower));

test('version and metadata', () => {
  assert.equal(lib.version, '1.0.0');
  const a = lib.open(caseBytes('valid', 'k2_cubic'));
  try {
    assert.equal(a.dim, 2);
    assert.equal(a.degree, 3);
    assert.ok(Number.isInteger(a.elementCount) && a.elementCount > 1);
    assert.deepEqual(a.parameters.map((p) => p.name), ['bend', 'twist']);
    for (const p of a.parameters) assert.ok(p.lower < p.upper && typeof p.unit === 'string');
    assert.deepEqual(a.fields.map((f) => [f.name, f.location, f.components]),
      [['temperature', 'vertex', 1], ['stress', 'tet', 1]]);
    assert.deepEqual(a.fields.map((f) => f.unit), ['', '']); // format 1.0: no units
    assert.ok(a.regions.length > 0);
    for (const r of a.regions) assert.ok(r.faceTags instanceof Int32Array && r.name && r.kind);
    assert.equal(a.provenance.builderVersion, '1.0.0');
    assert.equal(JSON.parse(a.provenance.options).K, 2); // options are JSON
    assert.deepEqual(a.infeasiblePoints, []);
  } finally {
    a.close();
  }
});

test('field units (format 1.1) come from the asset; the native runtime agrees', () => {
  const a = lib.open(caseBytes('valid', 'k1_units'));
  try {
    // The generator (src/tools/make_conformance.cpp) gives temperature K and stress MPa; the
    // native runner checks the same through cadinterp_field_unit (expected.txt "unit" lines).
    assert.deepEqual(a.fields.map((f) => [f.name, f.unit]), [['temperature', 'K'], ['stress', 'MPa']]);
    const m = a.eval(inner(a, [0.4]), ['stress'], { copy: true }); // units change nothing else
    assert.ok(m.fields.stress.length === m.tetCount);
  } finally {
    a.close();
  }
});

test('eval returns consistent arrays; views change, copies do not', () => {
  const a = lib.open(caseBytes('valid', 'k2_cubic'));
  try {
    const x = inner(a, [0.3, 0.7]);
    const m = a.eval(x);
    assert.equal(m.positions.length, 3 * m.vertexCount);
    assert.equal(m.tets.length, 4 * m.tetCount);
    assert.equal(m.triangles.length, 3 * m.triangleCount);
    assert.equal(m.triangleTags.length, m.triangleCount);
    assert.equal(m.fields.temperature.length, m.vertexCount);
    assert.equal(m.fields.stress.length, m.tetCount);
    for (const i of m.tets) assert.ok(i < m.vertexCount);
    for (const i of m.triangles) assert.ok(i < m.vertexCount);
    assert.deepEqual(Object.keys(a.eval(x, ['stress']).fields), ['stress']);
    assert.deepEqual(Object.keys(a.eval(x, []).fields), []);
    const c = a.eval(x, null, { copy: true });
    const saved = Array.from(c.positions);
    a.eval(inner(a, [0.9, 0.1]));
    assert.deepEqual(Array.from(c.positions), saved, 'a copy survives later calls');
    assert.ok(a.eval(x).positions.every((v, i) => v === saved[i]), 'eval is deterministic');
    // The element a point is assigned to is the one locate reports.
    assert.equal(a.locate(x).element, c.element);
    assert.equal(a.locate(x).feasible, true);
    assert.equal(typeof a.errorEstimate(x), 'number');
  } finally {
    a.close();
  }
});

// Central differences of eval in every direction at points whose +-h neighbours stay in the
// element (derivatives are per element for linear assets, C2 for cubic ones).
for (const name of ['k2_cubic', 'k3_cubic', 'k4_linear']) {
  test(`grad matches finite differences of eval (${name})`, () => {
    const a = lib.open(caseBytes('valid', name));
    try {
      const fields = a.fields.map((f) => f.name);
      const rand = rng(7);
      // h balances the truncation error of cubic assets (O(h^2)) against the float32 rounding of
      // the evaluated values, which the difference divides by 2h: the tolerance adds that noise
      // (a few float32 ulps of the largest value per array).
      const h = 1e-2;
      let checked = 0;
      let largest = 0;
      for (let trial = 0; trial < 6; ++trial) {
        const x = a.parameters.map((p) => p.lower + (0.05 + 0.9 * rand()) * (p.upper - p.lower));
        const g = a.grad(x, fields, { copy: true });
        const m = a.eval(x, fields, { copy: true });
        assert.deepEqual(Array.from(g.positions), Array.from(m.positions), 'grad positions = eval positions');
        assert.equal(g.dpositions.length, a.dim * 3 * m.vertexCount);
        for (let d = 0; d < a.dim; ++d) {
          const xp = x.slice(), xm = x.slice();
          xp[d] += h; xm[d] -= h;
          const mp = a.eval(xp, fields, { copy: true });
          const mm = a.eval(xm, fields, { copy: true });
          if (mp.element !== m.element || mm.element !== m.element) continue;
          const cmp = (got, plus, minus, what) => {
            let big = 0;
            for (let i = 0; i < plus.length; ++i) big = Math.max(big, Math.abs(plus[i]), Math.abs(minus[i]));
            const noise = (16 * 2 ** -24 * big) / (2 * h);
            for (let i = 0; i < plus.length; ++i) {
              const fd = (plus[i] - minus[i]) / (2 * h);
              largest = Math.max(largest, Math.abs(fd));
              const tol = 2e-3 * (1 + Math.abs(fd)) + noise;
              assert.ok(Math.abs(got[i] - fd) <= tol, `${what}[${i}] d${d} at ${x}: grad ${got[i]}, fd ${fd}`);
            }
          };
          const n3 = 3 * m.vertexCount;
          cmp(g.dpositions.subarray(d * n3, (d + 1) * n3), mp.positions, mm.positions, 'dpositions');
          for (const f of fields) {
            const n = m.fields[f].length;
            cmp(g.dfields[f].subarray(d * n, (d + 1) * n), mp.fields[f], mm.fields[f], `d${f}`);
          }
          ++checked;
        }
      }
      assert.ok(checked >= 4, `only ${checked} directions had both neighbours in the element`);
      assert.ok(largest > 0.05, 'the derivatives are not all (near) zero');
    } finally {
      a.close();
    }
  });
}

for (const name of ['k2_cubic', 'k4_linear']) {
  test(`vjp equals the adjoint contracted with grad (${name})`, () => {
    const a = lib.open(caseBytes('valid', name));
    try {
      const rand = rng(11);
      for (let trial = 0; trial < 4; ++trial) {
        const x = a.parameters.map((p) => p.lower + (0.05 + 0.9 * rand()) * (p.upper - p.lower));
        const g = a.grad(x, ['temperature', 'stress'], { copy: true });
        const m = a.eval(x, ['stress'], { copy: true });
        const V = g.vertexCount, T = m.tetCount;
        const dP = Float32Array.from({ length: 3 * V }, () => rand() * 2 - 1);
        const dTemp = Float32Array.from({ length: V }, () => rand() * 2 - 1);
        const dStress = Float32Array.from({ length: T }, () => rand() * 2 - 1);
        const cases = [
          [dP, null],
          [dP, { temperature: dTemp, stress: dStress }],
          [null, { stress: dStress }],
        ];
        for (const [pos, adj] of cases) {
          const want = new Float64Array(a.dim);
          const scale = new Float64Array(a.dim);
          for (let d = 0; d < a.dim; ++d) {
            const add = (u, arr, n) => {
              for (let i = 0; i < n; ++i) { want[d] += u[i] * arr[d * n + i]; scale[d] += Math.abs(u[i] * arr[d * n + i]); }
            };
            if (pos) add(pos, g.dpositions, 3 * V);
            if (adj?.temperature) add(adj.temperature, g.dfields.temperature, V);
            if (adj?.stress) add(adj.stress, g.dfields.stress, T);
          }
          const got = a.vjp(x, pos, adj);
          assert.ok(got instanceof Float64Array && got.length === a.dim);
          for (let d = 0; d < a.dim; ++d) {
            assert.ok(Math.abs(got[d] - want[d]) <= 1e-5 * (1 + scale[d]), `vjp[${d}] ${got[d]} vs ${want[d]}`);
          }
        }
        // An adjoint that is a view of the module's memory (an eval result) works like a copy.
        const viaCopy = a.vjp(x, a.eval(x, [], { copy: true }).positions);
        const viaView = a.vjp(x, a.eval(x, []).positions);
        assert.deepEqual(Array.from(viaView), Array.from(viaCopy));
        // Lengths are checked against the element (the C ABI itself cannot).
        throwsStatus(() => a.vjp(x, new Float32Array(3 * V - 1)), 'CADINTERP_E_INVALID_ARGUMENT');
        throwsStatus(() => a.vjp(x, null, { stress: new Float32Array(V === T ? T + 1 : V) }), 'CADINTERP_E_INVALID_ARGUMENT');
        throwsStatus(() => a.vjp(x, dP, { nope: dTemp }), 'CADINTERP_E_NOT_FOUND');
      }
    } finally {
      a.close();
    }
  });
}

// Volume, area, centroid and inertia of the evaluated mesh, summed here over its tets and
// boundary triangles (closed-form tetrahedron moments).
function meshProperties(m, density, dir) {
  const P = m.positions;
  let vol = 0, area = 0, front = 0;
  const first = [0, 0, 0];
  const second = [0, 0, 0, 0, 0, 0, 0, 0, 0]; // integral of x x^T dV
  const v = (i) => [P[3 * i], P[3 * i + 1], P[3 * i + 2]];
  for (let t = 0; t < m.tetCount; ++t) {
    const [a, b, c, d] = [0, 1, 2, 3].map((k) => v(m.tets[4 * t + k]));
    const e1 = b.map((q, i) => q - a[i]), e2 = c.map((q, i) => q - a[i]), e3 = d.map((q, i) => q - a[i]);
    const det = e1[0] * (e2[1] * e3[2] - e2[2] * e3[1]) - e1[1] * (e2[0] * e3[2] - e2[2] * e3[0]) + e1[2] * (e2[0] * e3[1] - e2[1] * e3[0]);
    const tv = det / 6;
    vol += tv;
    const pts = [a, b, c, d];
    const s = [0, 1, 2].map((i) => pts.reduce((acc, p) => acc + p[i], 0));
    for (let i = 0; i < 3; ++i) {
      first[i] += tv * s[i] / 4;
      for (let j = 0; j < 3; ++j) {
        const sum = pts.reduce((acc, p) => acc + p[i] * p[j], 0) + s[i] * s[j];
        second[3 * i + j] += tv * sum / 20;
      }
    }
  }
  for (let f = 0; f < m.triangleCount; ++f) {
    const [a, b, c] = [0, 1, 2].map((k) => v(m.triangles[3 * f + k]));
    const e1 = b.map((q, i) => q - a[i]), e2 = c.map((q, i) => q - a[i]);
    const n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    area += Math.hypot(...n) / 2;
    front += Math.abs(n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2]) / 4;
  }
  const centroid = first.map((q) => q / vol);
  const inertia = [];
  const C = second.map((q, k) => density * (q - vol * centroid[Math.floor(k / 3)] * centroid[k % 3]));
  const tr = C[0] + C[4] + C[8];
  for (let k = 0; k < 9; ++k) inertia.push((k % 4 === 0 ? tr : 0) - C[k]);
  return { volume: vol, mass: density * vol, area, frontalArea: front, centroid, inertia };
}

test('evalSubset returns the rows of eval for the ids asked, and refuses bad ids', () => {
  const a = lib.open(caseBytes('valid', 'k2_cubic'));
  try {
    const r = rng(7);
    for (let trial = 0; trial < 5; ++trial) {
      const x = inner(a, [r(), r()]);
      const full = a.eval(x, ['stress', 'temperature'], { copy: true });
      // The boundary vertices in reverse order with one repeated, every third tet.
      const vertices = Uint32Array.from(new Set(full.triangles)).reverse();
      const vlist = [...vertices, vertices[0]];
      const tets = [];
      for (let t = 0; t < full.tetCount; t += 3) tets.push(t);
      for (const vs of [Uint32Array.from(vlist), vlist]) {
        const m = a.evalSubset(x, { vertices: vs, tets }, ['stress', 'temperature'], { copy: true });
        assert.equal(m.element, full.element);
        assert.equal(m.vertexCount, full.vertexCount);
        assert.equal(m.tetCount, full.tetCount);
        assert.deepEqual(m.triangles, full.triangles);
        assert.equal(m.positions.length, 3 * vlist.length);
        assert.equal(m.fields.temperature.length, vlist.length);
        assert.equal(m.fields.stress.length, tets.length);
        // Same kernel order, no fused multiply-adds in WebAssembly: equal, not just close.
        vlist.forEach((v, i) => {
          for (let c = 0; c < 3; ++c) assert.equal(m.positions[3 * i + c], full.positions[3 * v + c]);
          assert.equal(m.fields.temperature[i], full.fields.temperature[v]);
        });
        tets.forEach((t, i) => assert.equal(m.fields.stress[i], full.fields.stress[t]));
      }
    }
    const x = inner(a, [0.3, 0.6]);
    const { vertexCount, tetCount } = a.eval(x, []);
    const empty = a.evalSubset(x, {}, []);
    assert.equal(empty.vertexCount, vertexCount);
    assert.equal(empty.positions.length, 0);
    throwsStatus(() => a.evalSubset(x, { vertices: [0, vertexCount] }, []), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.evalSubset(x, { tets: Uint32Array.of(tetCount) }, ['stress']), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.evalSubset(x, { vertices: [-1] }, []), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.evalSubset(x, { vertices: [0.5] }, []), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.evalSubset(x, { vertices: 3 }, []), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.evalSubset(x, { vertices: [0] }, ['nope']), 'CADINTERP_E_NOT_FOUND');
    throwsStatus(() => a.evalSubset([2, 2].map((v, d) => a.parameters[d].upper + v), { vertices: [0] }, []), 'CADINTERP_E_OUTSIDE_DOMAIN');
  } finally {
    a.close();
  }
  assert.throws(() => a.evalSubset([0, 0], {}, []), /closed/);
});

test('properties match sums over the evaluated mesh, and their grad matches finite differences', () => {
  const a = lib.open(caseBytes('valid', 'k3_cubic'));
  try {
    const x = inner(a, [0.35, 0.6, 0.45]);
    const dir = [0.6, 0, 0.8];
    const p = a.properties(x, { density: 2.5, direction: dir, grad: true });
    const want = meshProperties(a.eval(x, [], { copy: true }), 2.5, dir);
    const close = (g, w, what) => assert.ok(Math.abs(g - w) <= 1e-6 * (1 + Math.abs(w)), `${what}: ${g} vs ${w}`);
    close(p.volume, want.volume, 'volume');
    close(p.mass, want.mass, 'mass');
    close(p.area, want.area, 'area');
    close(p.frontalArea, want.frontalArea, 'frontalArea');
    p.centroid.forEach((c, i) => close(c, want.centroid[i], `centroid[${i}]`));
    p.inertia.forEach((c, i) => close(c, want.inertia[i], `inertia[${i}]`));
    assert.ok(p.volume > 0 && p.area > 0);
    // Defaults: density 1, direction +z, no grad.
    const q = a.properties(x);
    close(q.mass, q.volume, 'default density');
    assert.equal(q.grad, undefined);
    close(q.frontalArea, meshProperties(a.eval(x, [], { copy: true }), 1, [0, 0, 1]).frontalArea, 'default direction');
    // d/dx by central differences.
    assert.equal(p.grad.length, a.dim);
    const h = 1e-3;
    const el = a.locate(x).element;
    for (let d = 0; d < a.dim; ++d) {
      const xp = x.slice(), xm = x.slice();
      xp[d] += h; xm[d] -= h;
      assert.equal(a.locate(xp).element, el);
      assert.equal(a.locate(xm).element, el);
      const pp = a.properties(xp, { density: 2.5, direction: dir });
      const pm = a.properties(xm, { density: 2.5, direction: dir });
      for (const k of ['volume', 'mass', 'area', 'frontalArea']) {
        const fd = (pp[k] - pm[k]) / (2 * h);
        assert.ok(Math.abs(p.grad[d][k] - fd) <= 1e-3 * (1 + Math.abs(fd)), `d${k}/dx${d}: ${p.grad[d][k]} vs ${fd}`);
      }
      for (let i = 0; i < 3; ++i) {
        const fd = (pp.centroid[i] - pm.centroid[i]) / (2 * h);
        assert.ok(Math.abs(p.grad[d].centroid[i] - fd) <= 1e-3 * (1 + Math.abs(fd)), `dcentroid/dx${d}`);
      }
    }
  } finally {
    a.close();
  }
});

test('outside the domain, non-finite and malformed x', () => {
  const a = lib.open(caseBytes('valid', 'k3_linear'));
  try {
    const x = inner(a, [0.5]);
    const bad = [
      x.map((v, d) => (d === 1 ? a.parameters[d].upper + 0.25 : v)),
      x.map((v, d) => (d === 0 ? a.parameters[d].lower - 1e-3 : v)),
      x.map((v, d) => (d === 2 ? NaN : v)),
      x.map((v, d) => (d === 2 ? Infinity : v)),
    ];
    for (const b of bad) {
      throwsStatus(() => a.eval(b), 'CADINTERP_E_OUTSIDE_DOMAIN');
      throwsStatus(() => a.grad(b), 'CADINTERP_E_OUTSIDE_DOMAIN');
      throwsStatus(() => a.vjp(b, null), 'CADINTERP_E_OUTSIDE_DOMAIN');
      throwsStatus(() => a.properties(b), 'CADINTERP_E_OUTSIDE_DOMAIN');
      throwsStatus(() => a.locate(b), 'CADINTERP_E_OUTSIDE_DOMAIN');
      throwsStatus(() => a.errorEstimate(b), 'CADINTERP_E_OUTSIDE_DOMAIN');
    }
    throwsStatus(() => a.eval(x.slice(1)), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.eval([...x, 0.5]), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.eval(x.map(String)), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.eval(undefined), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.eval(x, ['no such field']), 'CADINTERP_E_NOT_FOUND');
    throwsStatus(() => a.properties(x, { direction: [1, 0] }), 'CADINTERP_E_INVALID_ARGUMENT');
    throwsStatus(() => a.setCacheBudget(-1), 'CADINTERP_E_INVALID_ARGUMENT');
    // Float64Array input and an eval after the errors still work.
    assert.equal(a.eval(Float64Array.from(x)).positions.length % 3, 0);
  } finally {
    a.close();
  }
});

test('infeasible points', () => {
  const a = lib.open(caseBytes('valid', 'k2_infeasible'));
  try {
    const x = [0.99, 0.99]; // the host fails where all parameters exceed 0.8
    assert.equal(a.locate(x).feasible, false);
    throwsStatus(() => a.eval(x), 'CADINTERP_E_INFEASIBLE');
    throwsStatus(() => a.grad(x), 'CADINTERP_E_INFEASIBLE');
    throwsStatus(() => a.vjp(x, null), 'CADINTERP_E_INFEASIBLE');
    throwsStatus(() => a.properties(x), 'CADINTERP_E_INFEASIBLE');
    assert.equal(a.locate([0.2, 0.2]).feasible, true);
    assert.ok(a.eval([0.2, 0.2]).vertexCount > 0);
  } finally {
    a.close();
  }
});

test('close is idempotent and every later call throws', () => {
  const a = lib.open(caseBytes('valid', 'k2_linear'));
  const x = inner(a, [0.5]);
  a.eval(x);
  a.close();
  a.close();
  for (const call of [
    () => a.eval(x), () => a.grad(x), () => a.vjp(x, null), () => a.properties(x),
    () => a.locate(x), () => a.errorEstimate(x), () => a.setCacheBudget(1 << 20),
  ]) throwsStatus(call, 'CADINTERP_E_INVALID_ARGUMENT');
});

test('open accepts ArrayBuffer and offset views, and rejects other inputs', () => {
  const bytes = caseBytes('valid', 'k1_linear');
  const padded = new Uint8Array(bytes.length + 16);
  padded.set(bytes, 5);
  const fromView = lib.open(padded.subarray(5, 5 + bytes.length));
  const fromBuffer = lib.open(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.length));
  try {
    assert.deepEqual(Array.from(fromView.eval([0.4]).positions), Array.from(fromBuffer.eval([0.4]).positions));
    padded.fill(0); // the asset keeps its own copy
    assert.ok(fromView.eval([0.6]).vertexCount > 0);
  } finally {
    fromView.close();
    fromBuffer.close();
  }
  throwsStatus(() => lib.open('asset.cadi'), 'CADINTERP_E_INVALID_ARGUMENT');
  throwsStatus(() => lib.open(null), 'CADINTERP_E_INVALID_ARGUMENT');
  throwsStatus(() => lib.open(new Uint8Array(0)), 'CADINTERP_E_BAD_MAGIC');
});

test('a zero cache budget still evaluates correctly', () => {
  const a = lib.open(caseBytes('valid', 'k2_cubic'));
  try {
    const x1 = inner(a, [0.2, 0.3]), x2 = inner(a, [0.8, 0.9]);
    const want1 = Array.from(a.eval(x1).positions), want2 = Array.from(a.eval(x2).positions);
    a.setCacheBudget(0);
    for (let i = 0; i < 3; ++i) {
      assert.deepEqual(Array.from(a.eval(x1).positions), want1);
      assert.deepEqual(Array.from(a.eval(x2).positions), want2);
    }
    a.setCacheBudget(2 ** 40); // beyond size_t on wasm32: means everything
  } finally {
    a.close();
  }
});

test('several assets at once: independent workspaces, region tags on the boundary', () => {
  const a = lib.open(caseBytes('valid', 'k2_cubic'));
  const b = lib.open(caseBytes('valid', 'k4_linear'));
  try {
    const xa = inner(a, [0.3, 0.6]), xb = inner(b, [0.7, 0.2, 0.4, 0.5]);
    const wantA = Array.from(a.eval(xa, null, { copy: true }).positions);
    const wantB = Array.from(b.eval(xb, null, { copy: true }).positions);
    for (let i = 0; i < 3; ++i) {
      const ma = a.eval(xa);
      const mb = b.eval(xb);
      assert.deepEqual(Array.from(ma.positions), wantA);
      assert.deepEqual(Array.from(mb.positions), wantB);
    }
    // Every region's face tags occur among the boundary triangles' tags.
    const m = a.eval(xa);
    const tags = new Set(m.triangleTags);
    for (const r of a.regions) for (const t of r.faceTags) assert.ok(tags.has(t), `region ${r.name} tag ${t}`);
  } finally {
    a.close();
    b.close();
  }
});
