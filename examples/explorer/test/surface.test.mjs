// Unit tests of the page's surface bookkeeping (src/surface.js) on meshes whose answers are
// known by hand: a unit right tetrahedron, and a unit cube split into the 6 Kuhn tets.
import assert from 'node:assert/strict';
import { describe, it } from 'node:test';
import { Surface, fieldMax, fieldRange } from '../src/surface.js';

/** Boundary faces of a tet mesh, oriented outward (the face opposite each vertex, turned away
 *  from it), tagged by the outward normal's dominant axis: 1..6 for -x, +x, -y, +y, -z, +z. */
function boundary(positions, tets) {
  const faces = new Map();
  for (let t = 0; t < tets.length / 4; ++t) {
    const v = tets.slice(4 * t, 4 * t + 4);
    for (let k = 0; k < 4; ++k) {
      const f = v.filter((_, j) => j !== k);
      const key = [...f].sort((a, b) => a - b).join();
      if (faces.has(key)) faces.delete(key);
      else faces.set(key, { f, opposite: v[k] });
    }
  }
  const tris = [], tags = [];
  const P = (i) => positions.slice(3 * i, 3 * i + 3);
  for (const { f, opposite } of faces.values()) {
    const [a, b, c] = f.map(P), o = P(opposite);
    const u = a.map((x, i) => b[i] - x), w = a.map((x, i) => c[i] - x);
    const n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
    const away = n[0] * (a[0] - o[0]) + n[1] * (a[1] - o[1]) + n[2] * (a[2] - o[2]);
    const tri = away > 0 ? f : [f[0], f[2], f[1]];
    const nn = away > 0 ? n : n.map((x) => -x);
    const axis = [0, 1, 2].reduce((m, i) => (Math.abs(nn[i]) > Math.abs(nn[m]) ? i : m), 0);
    tris.push(...tri);
    tags.push(1 + 2 * axis + (nn[axis] > 0 ? 1 : 0));
  }
  return { triangles: Uint32Array.from(tris), triangleTags: Int32Array.from(tags) };
}

function cube() {
  // Vertex i at (i&1, i>>1&1, i>>2&1), plus an interior-free Kuhn split along the 0-7 diagonal,
  // and one extra vertex (index 8) used by no triangle, as interior vertices are.
  const positions = [];
  for (let i = 0; i < 8; ++i) positions.push(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  positions.push(0.5, 0.5, 0.5);
  const paths = [[1, 2, 4], [1, 4, 2], [2, 1, 4], [2, 4, 1], [4, 1, 2], [4, 2, 1]];
  const tets = [];
  for (const p of paths) {
    let v = 0;
    const tet = [0];
    for (const s of p) tet.push((v |= s));
    tets.push(...tet);
  }
  const pos = Float32Array.from(positions);
  const t = Uint32Array.from(tets);
  return { vertexCount: 9, tetCount: 6, positions: pos, tets: t, element: 0, ...boundary(positions, tets) };
}

describe('Surface', () => {
  it('compacts the boundary of the Kuhn cube: 8 surface vertices, 12 triangles', () => {
    const m = cube();
    const s = new Surface();
    assert.equal(s.sync(m), true);
    assert.equal(s.surfaceVertexCount, 8);
    assert.equal(s.triangleCount, 12);
    assert.ok(!Array.from(s.surfaceVertices).includes(8), 'the unused vertex is not drawn');
    const pos = new Float32Array(3 * 8);
    s.gatherPositions(m.positions, pos);
    s.surfaceVertices.forEach((id, k) => assert.deepEqual(Array.from(pos.slice(3 * k, 3 * k + 3)), Array.from(m.positions.slice(3 * id, 3 * id + 3))));
    // Same element: nothing to redo.
    assert.equal(s.sync(m), false);
  });

  it('gives corner normals along the cube diagonal, outward', () => {
    const m = cube();
    const s = new Surface();
    s.sync(m);
    const pos = new Float32Array(24), nrm = new Float32Array(24);
    s.gatherPositions(m.positions, pos);
    s.computeNormals(pos, nrm);
    for (let k = 0; k < 8; ++k) {
      const p = pos.slice(3 * k, 3 * k + 3), n = nrm.slice(3 * k, 3 * k + 3);
      assert.ok(Math.abs(Math.hypot(...n) - 1) < 1e-6);
      // Outward: along p - centre, component by component in sign.
      for (let c = 0; c < 3; ++c) assert.ok(Math.sign(n[c]) === Math.sign(p[c] - 0.5), `vertex ${k}: ${n}`);
    }
  });

  it('finds each face region\'s centroid, area and outward normal', () => {
    const m = cube();
    const s = new Surface();
    s.sync(m);
    const pos = new Float32Array(24);
    s.gatherPositions(m.positions, pos);
    const expect = { 1: [[0, 0.5, 0.5], [-1, 0, 0]], 2: [[1, 0.5, 0.5], [1, 0, 0]], 6: [[0.5, 0.5, 1], [0, 0, 1]] };
    for (const [tag, [c, n]] of Object.entries(expect)) {
      const f = s.regionFrame(pos, [Number(tag)]);
      assert.equal(f.triangles, 2);
      assert.ok(Math.abs(f.area - 1) < 1e-6);
      f.centroid.forEach((v, i) => assert.ok(Math.abs(v - c[i]) < 1e-6, `tag ${tag}: centroid ${f.centroid}`));
      f.outwardNormal.forEach((v, i) => assert.ok(Math.abs(v - n[i]) < 1e-6, `tag ${tag}: normal ${f.outwardNormal}`));
    }
    assert.equal(s.regionFrame(pos, [99]), null);
    assert.equal(s.regionIndex([1, 2]).length, 12);
  });

  it('averages a per-vertex traction over a region by area (exact for a linear field)', () => {
    const m = cube();
    const s = new Surface();
    s.sync(m);
    const pos = new Float32Array(24);
    s.gatherPositions(m.positions, pos);
    // t(p) = (x, 2 y, 3 - z), indexed by the full mesh's vertex ids: its mean over a unit face is
    // its value at the face centre (linear field, the triangles' integral is exact).
    const t = new Float32Array(3 * m.vertexCount);
    for (let v = 0; v < m.vertexCount; ++v) {
      const [x, y, z] = m.positions.subarray(3 * v, 3 * v + 3);
      t.set([x, 2 * y, 3 - z], 3 * v);
    }
    const expect = { 1: [0, 1, 2.5], 2: [1, 1, 2.5], 6: [0.5, 1, 2] };
    for (const [tag, want] of Object.entries(expect)) {
      const f = s.regionFrame(pos, [Number(tag)], t);
      f.meanTraction.forEach((v, i) => assert.ok(Math.abs(v - want[i]) < 1e-6, `tag ${tag}: ${f.meanTraction}`));
    }
    // Two faces together: weighted by their (equal) areas.
    const both = s.regionFrame(pos, [1, 2], t).meanTraction;
    [0.5, 1, 2.5].forEach((w, i) => assert.ok(Math.abs(both[i] - w) < 1e-6, `${both}`));
    // The same traction as a subset eval returns it (one row per surface vertex): same means.
    const rows = new Float32Array(3 * s.surfaceVertexCount);
    s.surfaceVertices.forEach((v, i) => rows.set(t.subarray(3 * v, 3 * v + 3), 3 * i));
    for (const tag of [1, 2, 6]) {
      assert.deepEqual(s.regionFrame(pos, [tag], rows, true).meanTraction, s.regionFrame(pos, [tag], t).meanTraction);
    }
    assert.equal(s.regionFrame(pos, [1]).meanTraction, null);
  });

  it('averages per-tet values over the tets owning a vertex\'s boundary triangles', () => {
    const m = cube();
    const s = new Surface();
    s.sync(m);
    // Tet t has value t: each boundary triangle's value is its own tet's, found through the
    // triangle's three vertices.
    const values = Float32Array.from([0, 1, 2, 3, 4, 5]);
    const out = new Float32Array(8);
    s.vertexValues(values, 'tet', 1, out);
    // Vertex 0 and 7 touch all 6 tets' boundary triangles (two per tet, around the diagonal
    // ends): the mean of 0..5 is 2.5.
    const k0 = Array.from(s.surfaceVertices).indexOf(0), k7 = Array.from(s.surfaceVertices).indexOf(7);
    assert.ok(Math.abs(out[k0] - 2.5) < 1e-6 && Math.abs(out[k7] - 2.5) < 1e-6, `${out[k0]} ${out[k7]}`);
    // A constant per-tet field stays constant; a per-vertex vector field is drawn by magnitude.
    s.vertexValues(new Float32Array(6).fill(7), 'tet', 1, out);
    assert.deepEqual(Array.from(out), new Array(8).fill(7));
    const vec = new Float32Array(27);
    for (let v = 0; v < 9; ++v) vec.set([3 * v, 4 * v, 0], 3 * v);
    s.vertexValues(vec, 'vertex', 3, out);
    s.surfaceVertices.forEach((id, k) => assert.ok(Math.abs(out[k] - 5 * id) < 1e-5));
  });

  it('names the rows a subset eval needs, and draws from them what vertexValues draws from the whole mesh', () => {
    const m = cube();
    const s = new Surface();
    s.sync(m);
    const { vertices, tets } = s.subsetIds();
    // The 8 corners (not the unused vertex 8); every Kuhn tet owns two boundary triangles:
    // each tet once, ascending.
    assert.deepEqual(Array.from(vertices).sort(), [0, 1, 2, 3, 4, 5, 6, 7]);
    assert.deepEqual(Array.from(tets), [0, 1, 2, 3, 4, 5]);
    // A subset eval's rows, built here from whole-mesh arrays: per tet t value 10 t + 1, per
    // vertex v the vector (v, 2v, 2v) of magnitude 3v.
    const perTet = Float32Array.from([0, 1, 2, 3, 4, 5], (t) => 10 * t + 1);
    const perVertex = new Float32Array(27);
    for (let v = 0; v < 9; ++v) perVertex.set([v, 2 * v, 2 * v], 3 * v);
    const tetRows = Float32Array.from(tets, (t) => perTet[t]);
    const vertexRows = new Float32Array(3 * vertices.length);
    vertices.forEach((v, i) => vertexRows.set(perVertex.subarray(3 * v, 3 * v + 3), 3 * i));
    const want = new Float32Array(8), got = new Float32Array(8);
    s.vertexValues(perTet, 'tet', 1, want);
    s.surfaceValues(tetRows, 'tet', 1, got);
    assert.deepEqual(got, want);
    s.vertexValues(perVertex, 'vertex', 3, want);
    s.surfaceValues(vertexRows, 'vertex', 3, got);
    assert.deepEqual(got, want);
    vertices.forEach((v, k) => assert.ok(Math.abs(got[k] - 3 * v) < 1e-5));
  });

  it('coarsens a finely tessellated square for dragging: fewer triangles, same side, most of its area', () => {
    // The unit square z = 0 as a 60 x 60 grid of vertices, 2 triangles per cell, facing +z.
    const k = 60, positions = [], triangles = [];
    for (let j = 0; j < k; ++j) for (let i = 0; i < k; ++i) positions.push(i / (k - 1), j / (k - 1), 0);
    for (let j = 0; j + 1 < k; ++j)
      for (let i = 0; i + 1 < k; ++i) {
        const v = j * k + i;
        triangles.push(v, v + 1, v + k + 1, v, v + k + 1, v + k);
      }
    const s = new Surface();
    s.sync({ vertexCount: k * k, tetCount: 0, element: 0, positions: Float32Array.from(positions), tets: new Uint32Array(0),
      triangles: Uint32Array.from(triangles), triangleTags: new Int32Array(triangles.length / 3) });
    const pos = new Float32Array(3 * k * k), nrm = new Float32Array(3 * k * k);
    s.gatherPositions(Float32Array.from(positions), pos);
    s.computeNormals(pos, nrm);
    assert.equal(s.coarseIndex(pos, nrm, 10000), null, 'no coarse version of a surface already small enough');
    const c = s.coarseIndex(pos, nrm, 1000);
    assert.ok(c.length / 3 <= 1000 && c.length / 3 > 100, `${c.length / 3} triangles`);
    let area = 0;
    for (let t = 0; t < c.length; t += 3) {
      const [a, b, d] = [c[t], c[t + 1], c[t + 2]].map((v) => pos.subarray(3 * v, 3 * v + 3));
      const z = (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]);
      assert.ok(z >= 0, 'a coarse triangle turned over');
      area += z / 2;
    }
    // Clustering moves the rim inwards by less than a grid cell (at most 1/8 of the extent).
    assert.ok(area > 0.75 && area <= 1 + 1e-6, `area ${area}`);
  });

  it('adopts a new topology when the element changes to different arrays', () => {
    const s = new Surface();
    s.sync(cube());
    const one = { vertexCount: 4, tetCount: 1, element: 3, positions: Float32Array.from([0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]), tets: Uint32Array.from([0, 1, 2, 3]) };
    Object.assign(one, boundary(Array.from(one.positions), [0, 1, 2, 3]));
    assert.equal(s.sync(one), true);
    assert.equal(s.surfaceVertexCount, 4);
    assert.equal(s.triangleCount, 4);
    const out = new Float32Array(4);
    s.vertexValues(Float32Array.from([42]), 'tet', 1, out);
    assert.deepEqual(Array.from(out), [42, 42, 42, 42]);
  });
});

describe('field reductions', () => {
  it('max and range of scalar and vector fields', () => {
    assert.equal(fieldMax(Float32Array.from([1, -5, 3]), 1), 3);
    assert.deepEqual(fieldRange(Float32Array.from([1, -5, 3]), 1), [-5, 3]);
    assert.equal(fieldMax(Float32Array.from([3, 4, 0, 0, 0, 1]), 3), 5);
    assert.deepEqual(fieldRange(Float32Array.from([3, 4, 0, 0, 0, 1]), 3), [1, 5]);
  });
});
