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
      (this.tets === null || sameArray(m.tets, this.tets))
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
    this.version += 1;
    return true;
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
    const mag = (base) => {
      if (components === 1) return values[base];
      let s = 0;
      for (let c = 0; c < components; ++c) s += values[base + c] * values[base + c];
      return Math.sqrt(s);
    };
    if (location === 'vertex') {
      for (let i = 0; i < n; ++i) out[i] = mag(components * ids[i]);
      return;
    }
    this.#ensureTriangleTets();
    this.#ensureVertexTriangles();
    const start = this.vertexTriangleStart, list = this.vertexTriangles, owner = this.triangleTet;
    // Each boundary triangle's value once, then the per-vertex means (a vertex has ~6).
    const F = owner.length;
    if (!this.triangleValue || this.triangleValue.length !== F) this.triangleValue = new Float32Array(F);
    const tv = this.triangleValue;
    for (let f = 0; f < F; ++f) {
      const t = owner[f];
      tv[f] = t < 0 ? NaN : components === 1 ? values[t] : mag(components * t);
    }
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

  /** Area-weighted centroid, mean outward normal and area of the triangles with a tag in
   *  `tags`, on compact positions `pos`. */
  regionFrame(pos, tags, traction = null) {
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
        const p = 3 * tri[3 * f], q = 3 * tri[3 * f + 1], r = 3 * tri[3 * f + 2];
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
    let v;
    if (components === 1) v = values[i];
    else {
      let s = 0;
      for (let c = 0; c < components; ++c) s += values[i + c] * values[i + c];
      v = Math.sqrt(s);
    }
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
