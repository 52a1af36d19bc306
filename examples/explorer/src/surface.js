// The boundary surface of an evaluated tet mesh, as the page draws it.
//
// cadinterp_eval returns every vertex of the tet mesh (interior ones included) and the boundary
// triangles indexing them. Only the boundary is drawn, so per topology we compact the vertex set
// to the vertices the triangles use: per frame the page then gathers, lights and colours ~3-5x
// fewer vertices than the mesh has (for the 90k-vertex bracket, 16k).
//
// A topology is recomputed only when the evaluated element's arrays differ from the last ones:
// within one element, and across elements that share the stored topology (the bracket: all of
// them), slider moves only rewrite positions and values in place.

/** Whether two typed arrays hold the same values. */
function sameArray(a, b) {
  if (!a || !b || a.length !== b.length) return false;
  for (let i = 0; i < a.length; ++i) if (a[i] !== b[i]) return false;
  return true;
}

export class Surface {
  constructor() {
    this.vertexCount = 0; // of the whole tet mesh
    this.tetCount = 0;
    this.triangles = null; // copy of the mesh's boundary triangles (original vertex ids)
    this.tets = null; // copy (needed for per-tet fields)
    this.triangleTags = null;
    this.surfaceVertices = null; // Uint32Array: original id of each surface vertex
    this.index = null; // Uint32Array: triangles in surface vertex ids
    this.triangleTet = null; // Int32Array: the tet owning each boundary triangle (lazy)
    this.vertexTriangles = null; // CSR: surface vertex -> its triangles (lazy)
    this.vertexTriangleStart = null;
    this.version = 0; // bumped on every topology change
    this.element = -1; // the element the current arrays came from
  }

  /** Adopts the topology of eval result `m` if it differs from the current one; returns true
   *  when it changed. */
  sync(m) {
    // One element has one topology: only a change of element can change it.
    if (this.element === m.element && this.version > 0) return false;
    this.element = m.element;
    if (
      m.vertexCount === this.vertexCount &&
      m.tetCount === this.tetCount &&
      sameArray(m.triangles, this.triangles) &&
      sameArray(m.triangleTags, this.triangleTags) &&
      (this.tets === null || this.#ownersHold(m.tets) || sameArray(m.tets, this.tets))
    ) {
      return false;
    }
    this.vertexCount = m.vertexCount;
    this.tetCount = m.tetCount;
    this.triangles = m.triangles.slice();
    this.triangleTags = m.triangleTags.slice();
    this.tets = m.tets.slice();
    const map = new Int32Array(m.vertexCount).fill(-1);
    const ids = [];
    const index = new Uint32Array(this.triangles.length);
    for (let i = 0; i < this.triangles.length; ++i) {
      const v = this.triangles[i];
      if (map[v] < 0) {
        map[v] = ids.length;
        ids.push(v);
      }
      index[i] = map[v];
    }
    this.surfaceVertices = Uint32Array.from(ids);
    this.index = index;
    this.triangleTet = null;
    this.vertexTriangles = null;
    this.subset = null;
    this.triangleRow = null;
    this.coarse = null;
    this.version += 1;
    return true;
  }

  /** Whether each boundary triangle's tet (when known) still holds its three vertices in `tets`:
   *  all the page takes from the tets, checked in O(#F) instead of comparing all 4 #T ids
   *  (17 ms on the 490k-tet bracket, at every change of element while dragging). */
  #ownersHold(tets) {
    const owner = this.triangleTet, tri = this.triangles;
    if (!owner) return false;
    for (let f = 0; f < owner.length; ++f) {
      const t = owner[f];
      if (t < 0) return false; // re-derived by the full comparison
      const a = tets[4 * t], b = tets[4 * t + 1], c = tets[4 * t + 2], d = tets[4 * t + 3];
      for (let k = 0; k < 3; ++k) {
        const v = tri[3 * f + k];
        if (v !== a && v !== b && v !== c && v !== d) return false;
      }
    }
    return true;
  }

  /**
   * A coarse version of the surface for drawing while a slider moves (software GL draws ~600k
   * triangles a second here, so 32k triangles cap a drag near 20 fps): vertex clustering
   * (Rossignac-Borrel) on a grid of the part's bounding box, where vertices of one cell whose
   * normals face the same way (dominant axis and sign: the two sides of a thin wall stay apart)
   * merge into the cell's first vertex, and triangles left with three distinct vertices are kept,
   * in their orientation. Its vertices are surface vertices, so the coarse mesh shows evaluated
   * positions, normals and colours, only fewer of them. The grid is the finest (of a few) giving
   * at most `target` triangles; computed once per topology from the positions and normals given.
   * Returns a Uint32Array of compact triangle indices, or null when the surface has no more than
   * `target` triangles anyway.
   */
  coarseIndex(pos, nrm, target) {
    if (this.coarse && this.coarse.target === target) return this.coarse.index;
    const n = this.surfaceVertexCount, idx = this.index;
    let index = null;
    if (idx.length / 3 > target) {
      const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
      for (let i = 0; i < n; ++i)
        for (let c = 0; c < 3; ++c) {
          const v = pos[3 * i + c];
          if (v < lo[c]) lo[c] = v;
          if (v > hi[c]) hi[c] = v;
        }
      const ext = Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) || 1;
      const rep = new Int32Array(n);
      for (const cells of [96, 64, 48, 32, 24, 16, 12, 8]) {
        const h = ext / cells, m = cells + 1;
        const first = new Map();
        for (let i = 0; i < n; ++i) {
          const nx = nrm[3 * i], ny = nrm[3 * i + 1], nz = nrm[3 * i + 2];
          const ax = Math.abs(nx), ay = Math.abs(ny), az = Math.abs(nz);
          const bin = ax >= ay && ax >= az ? (nx > 0 ? 0 : 1) : ay >= az ? (ny > 0 ? 2 : 3) : nz > 0 ? 4 : 5;
          const ix = Math.floor((pos[3 * i] - lo[0]) / h), iy = Math.floor((pos[3 * i + 1] - lo[1]) / h);
          const iz = Math.floor((pos[3 * i + 2] - lo[2]) / h);
          const key = ((ix * m + iy) * m + iz) * 6 + bin;
          let r = first.get(key);
          if (r === undefined) first.set(key, (r = i));
          rep[i] = r;
        }
        const out = [];
        for (let t = 0; t < idx.length; t += 3) {
          const a = rep[idx[t]], b = rep[idx[t + 1]], c = rep[idx[t + 2]];
          if (a !== b && b !== c && a !== c) out.push(a, b, c);
        }
        index = Uint32Array.from(out);
        if (out.length / 3 <= target) break;
      }
    }
    this.coarse = { target, index };
    return index;
  }

  get surfaceVertexCount() {
    return this.surfaceVertices ? this.surfaceVertices.length : 0;
  }
  get triangleCount() {
    return this.index ? this.index.length / 3 : 0;
  }

  /** Copies the surface vertices' positions out of the full position array. */
  gatherPositions(positions, out) {
    const ids = this.surfaceVertices;
    for (let i = 0; i < ids.length; ++i) {
      const s = 3 * ids[i];
      out[3 * i] = positions[s];
      out[3 * i + 1] = positions[s + 1];
      out[3 * i + 2] = positions[s + 2];
    }
  }

  /** Area-weighted vertex normals of the compact surface (outward: the triangles are CCW seen
   *  from outside). */
  computeNormals(pos, out) {
    const n = this.surfaceVertexCount;
    out.fill(0, 0, 3 * n);
    const idx = this.index;
    for (let t = 0; t < idx.length; t += 3) {
      const a = 3 * idx[t], b = 3 * idx[t + 1], c = 3 * idx[t + 2];
      const ux = pos[b] - pos[a], uy = pos[b + 1] - pos[a + 1], uz = pos[b + 2] - pos[a + 2];
      const vx = pos[c] - pos[a], vy = pos[c + 1] - pos[a + 1], vz = pos[c + 2] - pos[a + 2];
      // |u x v| is twice the area: summing unnormalized cross products weights by area.
      const nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      out[a] += nx; out[a + 1] += ny; out[a + 2] += nz;
      out[b] += nx; out[b + 1] += ny; out[b + 2] += nz;
      out[c] += nx; out[c + 1] += ny; out[c + 2] += nz;
    }
    // (Math.hypot is several times slower than this in V8, and this runs every frame.)
    for (let i = 0; i < 3 * n; i += 3) {
      const l = Math.sqrt(out[i] * out[i] + out[i + 1] * out[i + 1] + out[i + 2] * out[i + 2]);
      const inv = l > 0 ? 1 / l : 0;
      out[i] *= inv; out[i + 1] *= inv; out[i + 2] *= inv;
    }
  }

  /** For per-tet fields: each boundary triangle's tet (the one holding its three vertices). */
  #ensureTriangleTets() {
    if (this.triangleTet) return;
    const V = this.vertexCount, tets = this.tets, tri = this.triangles;
    // Incidence vertex -> tets, restricted to surface vertices (CSR over the whole id range).
    const onSurface = new Uint8Array(V);
    for (let i = 0; i < tri.length; ++i) onSurface[tri[i]] = 1;
    const count = new Int32Array(V + 1);
    for (let i = 0; i < tets.length; ++i) if (onSurface[tets[i]]) count[tets[i] + 1] += 1;
    for (let v = 0; v < V; ++v) count[v + 1] += count[v];
    const list = new Int32Array(count[V]);
    const fill = count.slice(0, V);
    for (let i = 0; i < tets.length; ++i) {
      const v = tets[i];
      if (onSurface[v]) list[fill[v]++] = i >> 2;
    }
    const F = tri.length / 3;
    const owner = new Int32Array(F).fill(-1);
    for (let f = 0; f < F; ++f) {
      const a = tri[3 * f], b = tri[3 * f + 1], c = tri[3 * f + 2];
      for (let k = count[a]; k < count[a + 1] && owner[f] < 0; ++k) {
        const t = list[k];
        let hasB = false, hasC = false;
        for (let j = 0; j < 4; ++j) {
          const w = tets[4 * t + j];
          hasB ||= w === b;
          hasC ||= w === c;
        }
        if (hasB && hasC) owner[f] = t;
      }
    }
    this.triangleTet = owner;
  }

  #ensureVertexTriangles() {
    if (this.vertexTriangles) return;
    const n = this.surfaceVertexCount, idx = this.index;
    const start = new Int32Array(n + 1);
    for (let i = 0; i < idx.length; ++i) start[idx[i] + 1] += 1;
    for (let v = 0; v < n; ++v) start[v + 1] += start[v];
    const list = new Int32Array(idx.length);
    const fill = start.slice(0, n);
    for (let i = 0; i < idx.length; ++i) list[fill[idx[i]]++] = (i / 3) | 0;
    this.vertexTriangleStart = start;
    this.vertexTriangles = list;
  }

  /**
   * One value per surface vertex for drawing a field: per-vertex fields are gathered, per-tet
   * fields are averaged over the tets owning the vertex's boundary triangles (the usual nodal
   * averaging of FE post-processing; the raw per-tet values still decide the readouts and the
   * colour range). Vector fields are drawn by magnitude.
   */
  vertexValues(values, location, components, out) {
    const n = this.surfaceVertexCount, ids = this.surfaceVertices;
    const mag = (base) => magnitude(values, base, components);
    if (location === 'vertex') {
      for (let i = 0; i < n; ++i) out[i] = mag(components * ids[i]);
      return;
    }
    this.#ensureTriangleTets();
    const owner = this.triangleTet;
    // Each boundary triangle's value once, then the per-vertex means (a vertex has ~6).
    const F = owner.length;
    if (!this.triangleValue || this.triangleValue.length !== F) this.triangleValue = new Float32Array(F);
    const tv = this.triangleValue;
    for (let f = 0; f < F; ++f) {
      const t = owner[f];
      tv[f] = t < 0 ? NaN : components === 1 ? values[t] : mag(components * t);
    }
    this.#meanOverTriangles(out);
  }

  /** out[i] = mean of this.triangleValue over surface vertex i's triangles (NaN ones skipped). */
  #meanOverTriangles(out) {
    this.#ensureVertexTriangles();
    const n = this.surfaceVertexCount, tv = this.triangleValue;
    const start = this.vertexTriangleStart, list = this.vertexTriangles;
    for (let i = 0; i < n; ++i) {
      let s = 0, k = 0;
      for (let j = start[i]; j < start[i + 1]; ++j) {
        const v = tv[list[j]];
        if (v === v) {
          s += v;
          k += 1;
        }
      }
      out[i] = k ? s / k : 0;
    }
  }

  /**
   * The rows the page evaluates per frame (cadinterp_eval_subset): the surface vertices (drawn,
   * per-vertex fields) and each boundary triangle's tet (per-tet fields; 0 stands in for a
   * triangle without one, whose value surfaceValues ignores). Fixed per topology.
   */
  subsetIds() {
    if (!this.subset) {
      this.#ensureTriangleTets();
      // Each owning tet once, in ascending order: a per-tet field's rows are then read from the
      // stored arrays front to back (the blend of scattered tets is bound by memory latency,
      // one cache line per tet and term), and a tet owning two boundary triangles once.
      const owners = Int32Array.from(this.triangleTet.filter((t) => t >= 0)).sort();
      const tets = [];
      for (let i = 0; i < owners.length; ++i) if (i === 0 || owners[i] !== owners[i - 1]) tets.push(owners[i]);
      const row = new Map(tets.map((t, i) => [t, i]));
      this.triangleRow = Int32Array.from(this.triangleTet, (t) => (t < 0 ? -1 : row.get(t)));
      this.subset = { vertices: this.surfaceVertices, tets: Uint32Array.from(tets) };
    }
    return this.subset;
  }

  /**
   * vertexValues for the rows of subsetIds(): `values` holds one row per surface vertex
   * (per-vertex fields) or per subsetIds().tets entry (per-tet fields).
   */
  surfaceValues(values, location, components, out) {
    const n = this.surfaceVertexCount;
    const mag = (base) => magnitude(values, base, components);
    if (location === 'vertex') {
      for (let i = 0; i < n; ++i) out[i] = mag(components * i);
      return;
    }
    this.subsetIds();
    const row = this.triangleRow, F = row.length;
    if (!this.triangleValue || this.triangleValue.length !== F) this.triangleValue = new Float32Array(F);
    const tv = this.triangleValue;
    for (let f = 0; f < F; ++f) tv[f] = row[f] < 0 ? NaN : mag(components * row[f]);
    this.#meanOverTriangles(out);
  }

  /** Area-weighted centroid, mean outward normal and area of the triangles with a tag in
   *  `tags`, on compact positions `pos`; `traction` is indexed by the full mesh's vertex ids,
   *  or with `compactTraction` by surface vertex (a subset eval's rows). */
  regionFrame(pos, tags, traction = null, compactTraction = false) {
    const tagSet = new Set(tags);
    const idx = this.index, triTags = this.triangleTags, tri = this.triangles;
    let area = 0, cx = 0, cy = 0, cz = 0, nx = 0, ny = 0, nz = 0, count = 0;
    let tx = 0, ty = 0, tz = 0;
    for (let f = 0; f < triTags.length; ++f) {
      if (!tagSet.has(triTags[f])) continue;
      const a = 3 * idx[3 * f], b = 3 * idx[3 * f + 1], c = 3 * idx[3 * f + 2];
      const ux = pos[b] - pos[a], uy = pos[b + 1] - pos[a + 1], uz = pos[b + 2] - pos[a + 2];
      const vx = pos[c] - pos[a], vy = pos[c + 1] - pos[a + 1], vz = pos[c + 2] - pos[a + 2];
      const x = uy * vz - uz * vy, y = uz * vx - ux * vz, z = ux * vy - uy * vx;
      const A = 0.5 * Math.hypot(x, y, z);
      area += A;
      cx += (A * (pos[a] + pos[b] + pos[c])) / 3;
      cy += (A * (pos[a + 1] + pos[b + 1] + pos[c + 1])) / 3;
      cz += (A * (pos[a + 2] + pos[b + 2] + pos[c + 2])) / 3;
      nx += 0.5 * x; ny += 0.5 * y; nz += 0.5 * z;
      count += 1;
      if (traction) {
        // Area-weighted mean of a per-vertex 3-vector field (indexed by the full mesh's vertex
        // ids): the integral of the linear interpolant over the triangle is A (t_a + t_b + t_c) / 3.
        const ids = compactTraction ? idx : tri;
        const p = 3 * ids[3 * f], q = 3 * ids[3 * f + 1], r = 3 * ids[3 * f + 2];
        tx += (A * (traction[p] + traction[q] + traction[r])) / 3;
        ty += (A * (traction[p + 1] + traction[q + 1] + traction[r + 1])) / 3;
        tz += (A * (traction[p + 2] + traction[q + 2] + traction[r + 2])) / 3;
      }
    }
    if (count === 0 || area === 0) return null;
    const l = Math.hypot(nx, ny, nz) || 1;
    return {
      area,
      triangles: count,
      centroid: [cx / area, cy / area, cz / area],
      outwardNormal: [nx / l, ny / l, nz / l],
      /** Area-weighted mean of `traction` over the region (null without it). */
      meanTraction: traction ? [tx / area, ty / area, tz / area] : null,
    };
  }

  /** The triangles (compact ids) whose tag is in `tags`. */
  regionIndex(tags) {
    const tagSet = new Set(tags);
    const out = [];
    for (let f = 0; f < this.triangleTags.length; ++f)
      if (tagSet.has(this.triangleTags[f])) out.push(this.index[3 * f], this.index[3 * f + 1], this.index[3 * f + 2]);
    return Uint32Array.from(out);
  }
}

/** The value at `base` of a field of `components` per row: itself, or the row's magnitude. */
function magnitude(values, base, components) {
  if (components === 1) return values[base];
  let s = 0;
  for (let c = 0; c < components; ++c) s += values[base + c] * values[base + c];
  return Math.sqrt(s);
}

/** Largest value (largest magnitude for vector fields) of a raw field array. */
export function fieldMax(values, components) {
  let m = -Infinity;
  if (components === 1) {
    for (let i = 0; i < values.length; ++i) {
      const v = values[i];
      m = v > m ? v : m;
    }
    return m;
  }
  for (let i = 0; i < values.length; i += components) {
    let s = 0;
    for (let c = 0; c < components; ++c) s += values[i + c] * values[i + c];
    if (s > m) m = s;
  }
  return Math.sqrt(m);
}

/** [min, max] of a raw field array (magnitudes for vector fields). */
export function fieldRange(values, components) {
  let lo = Infinity, hi = -Infinity;
  if (components === 1) {
    // The common case, kept branch-light: it runs over every tet (490k) every frame.
    for (let i = 0; i < values.length; ++i) {
      const v = values[i];
      lo = v < lo ? v : lo;
      hi = v > hi ? v : hi;
    }
    return [lo, hi];
  }
  for (let i = 0; i < values.length; i += components) {
    const v = magnitude(values, i, components);
    if (v < lo) lo = v;
    if (v > hi) hi = v;
  }
  return [lo, hi];
}

/**
 * Where, along parameter i with the others fixed at x, the asset is infeasible: `samples`
 * evenly spaced points asked of locate(); returns runs [from, to] in parameter units (each run
 * widened by half a step on both sides, since the boundary lies somewhere between samples).
 */
export function infeasibleRuns(asset, x, i, lower, upper, samples = 161) {
  const q = Float64Array.from(x);
  const runs = [];
  const step = (upper - lower) / (samples - 1);
  let start = -1;
  for (let s = 0; s < samples; ++s) {
    q[i] = s === samples - 1 ? upper : lower + s * step;
    let feasible;
    try {
      feasible = asset.locate(q).feasible;
    } catch {
      feasible = false;
    }
    if (!feasible && start < 0) start = s;
    if ((feasible || s === samples - 1) && start >= 0) {
      const end = feasible ? s - 1 : s;
      runs.push([Math.max(lower, lower + (start - 0.5) * step), Math.min(upper, lower + (end + 0.5) * step)]);
      start = -1;
    }
  }
  return runs;
}

/**
 * What the page takes from the whole mesh rather than from the drawn surface: the mass
 * properties at req.x (cadinterp_eval_properties) and the [min, max] of each field named in
 * req.ranges (magnitudes for vector fields) over all its vertices or tets, as the native runtime
 * computes them. Run by the properties worker (or by the page without one).
 */
export function propertiesAndRanges(asset, req) {
  const properties = asset.properties(req.x, { density: req.density, direction: req.direction });
  const ranges = {};
  const names = [...new Set(req.ranges ?? [])].filter((n) => asset.fields.some((f) => f.name === n));
  if (names.length) {
    const r = asset.eval(req.x, names);
    for (const n of names) ranges[n] = fieldRange(r.fields[n], asset.fields.find((f) => f.name === n).components);
  }
  return { properties, ranges };
}
