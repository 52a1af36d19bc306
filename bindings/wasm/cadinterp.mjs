// cadinterp for JavaScript: the runtime's C ABI (include/cadinterp/cadinterp.h) compiled to
// WebAssembly (cadinterp_wasm.{mjs,wasm}, built by scripts/build-wasm.sh), behind the API of
// bindings/wasm/README.md. Works in Node >= 18 and in browsers, as an ES module.
//
// Memory: each asset keeps its file bytes, one workspace and a small scratch block in the
// WebAssembly heap until close(); every call writes its inputs to the scratch block, so warm
// evaluations allocate nothing in the heap (test/memory.test.mjs checks it). Arrays returned
// without { copy: true } are views of the heap, like the C ABI's workspace pointers.
import createCadinterpModule from './cadinterp_wasm.mjs';

/** cadinterp_status names, indexed by value (cadinterp.h; values are only ever appended). */
export const STATUS_NAMES = Object.freeze([
  'CADINTERP_OK',
  'CADINTERP_E_INVALID_ARGUMENT',
  'CADINTERP_E_OUT_OF_MEMORY',
  'CADINTERP_E_IO',
  'CADINTERP_E_BAD_MAGIC',
  'CADINTERP_E_UNSUPPORTED_VERSION',
  'CADINTERP_E_TRUNCATED',
  'CADINTERP_E_CORRUPT_INDEX',
  'CADINTERP_E_CHECKSUM',
  'CADINTERP_E_OUT_OF_RANGE',
  'CADINTERP_E_LIMIT',
  'CADINTERP_E_CORRUPT_BLOB',
  'CADINTERP_E_OUTSIDE_DOMAIN',
  'CADINTERP_E_INFEASIBLE',
  'CADINTERP_E_INTERNAL',
  'CADINTERP_E_NOT_FOUND',
  'CADINTERP_E_CANCELLED',
  'CADINTERP_E_STORE_MISMATCH',
]);

const E_INVALID_ARGUMENT = 1;
const E_OUT_OF_MEMORY = 2;
const E_NOT_FOUND = 15;

/**
 * Every failure of the API: .status is the C ABI's cadinterp_status, .statusName its name,
 * .message the C ABI's detailed message (cadinterp_open_error / cadinterp_workspace_error), or
 * the wrapper's own for argument errors it detects first.
 */
export class CadinterpError extends Error {
  constructor(status, message) {
    const name = STATUS_NAMES[status] ?? `CADINTERP_STATUS_${status}`;
    super(message || name);
    this.name = 'CadinterpError';
    this.status = status;
    this.statusName = name;
  }
}

// Offsets of the C structs on wasm32, checked against cadinterp.h at compile time by
// wasm_glue.c (cadinterp_wasm_layout_version() names the set).
const LAYOUT_VERSION = 1;
const MESH_SIZE = 36;
const PROPS_SIZE = 128;
const MAX_DIM = 8;

// Per-asset scratch block: x, the output struct, K property gradients, small outputs, the
// direction, dF/dx, then the field index and adjoint pointer arrays (field count entries each).
const S_X = 0; // 8 doubles
const S_OUT = 64; // cadinterp_mesh | cadinterp_mesh_grad | cadinterp_properties (128)
const S_PGRAD = S_OUT + PROPS_SIZE; // K cadinterp_properties
const S_MISC = S_PGRAD + MAX_DIM * PROPS_SIZE; // int element, int feasible, double error
const S_DIR = S_MISC + 16; // 3 doubles
const S_DX = S_DIR + 24; // K doubles
const S_FIELDS = S_DX + 8 * MAX_DIM; // field count ints, then field count pointers

const isNode = typeof process === 'object' && process !== null && !!process.versions?.node;

// The module's default location: next to this file. A literal URL, so that bundlers (Vite,
// webpack 5, esbuild) recognise the asset and copy it along.
const defaultWasmUrl = () => new URL('./cadinterp_wasm.wasm', import.meta.url);

async function nodeWasmBinary(locateFile) {
  // A computed specifier: bundlers for the browser must not try to resolve a Node built-in.
  const fsModule = 'node:fs/promises';
  const { readFile } = await import(/* @vite-ignore */ /* webpackIgnore: true */ fsModule);
  let where = locateFile ? locateFile('cadinterp_wasm.wasm', '') : defaultWasmUrl();
  if (typeof where === 'string' && where.startsWith('file:')) where = new URL(where);
  return readFile(where);
}

/**
 * Loads the WebAssembly module.
 * @param {{wasmBinary?: ArrayBuffer|Uint8Array, locateFile?: (name: string, prefix: string) => string}} [options]
 * @returns {Promise<Library>}
 */
export async function load(options = {}) {
  const args = {};
  if (options.wasmBinary) {
    args.wasmBinary = options.wasmBinary instanceof ArrayBuffer ? new Uint8Array(options.wasmBinary) : options.wasmBinary;
  } else if (isNode) {
    // The module is built for the web loader only (no require/__dirname in an ES module):
    // in Node the binary is read here and handed over.
    args.wasmBinary = await nodeWasmBinary(options.locateFile);
  } else {
    args.locateFile = options.locateFile ?? ((name) => (name === 'cadinterp_wasm.wasm' ? defaultWasmUrl() : new URL(name, import.meta.url)).href);
  }
  const mod = await createCadinterpModule(args);
  if (mod._cadinterp_wasm_layout_version() !== LAYOUT_VERSION) {
    throw new CadinterpError(14, 'cadinterp_wasm.wasm and cadinterp.mjs come from different builds');
  }
  return new Library(mod);
}

/** The loaded module: opens assets. */
class Library {
  #mod;
  constructor(mod) {
    this.#mod = mod;
    /** Runtime version "MAJOR.MINOR.PATCH". */
    this.version = mod.UTF8ToString(mod._cadinterp_version());
    Object.freeze(this);
  }

  /**
   * Opens an asset (.cadi bytes). The bytes are copied into the WebAssembly heap: the caller's
   * buffer may be reused at once.
   * @param {ArrayBuffer|Uint8Array} bytes
   * @returns {Asset}
   */
  open(bytes) {
    let u8;
    if (bytes instanceof Uint8Array) u8 = bytes;
    else if (bytes instanceof ArrayBuffer) u8 = new Uint8Array(bytes);
    else if (ArrayBuffer.isView(bytes)) u8 = new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    else throw new CadinterpError(E_INVALID_ARGUMENT, 'open: expected an ArrayBuffer or a Uint8Array');
    // A view of this module's own memory would be detached if the allocation grows it.
    if (u8.buffer === this.#mod.HEAPU8.buffer) u8 = u8.slice();
    return new Asset(this.#mod, u8);
  }

  /**
   * Diagnostics: { heapBytes: size of the WebAssembly memory, mallocBytes: bytes allocated in it
   * and not freed }. The memory never shrinks; mallocBytes returns to its level when assets close.
   */
  memoryStats() {
    return { heapBytes: this.#mod.HEAPU8.buffer.byteLength, mallocBytes: this.#mod._cadinterp_wasm_heap_in_use() >>> 0 };
  }
}

// Frees what an asset holds in the heap if it is garbage-collected without close().
const finalizer = typeof FinalizationRegistry === 'function'
  ? new FinalizationRegistry(({ mod, ws, asset, data, scratch, ids }) => {
      if (ids) mod._free(ids);
      mod._cadinterp_workspace_destroy(ws);
      mod._cadinterp_close(asset);
      mod._free(data);
      mod._free(scratch);
    })
  : null;

function readProps(f64, p) {
  const i = p >> 3;
  return {
    volume: f64[i],
    mass: f64[i + 1],
    area: f64[i + 2],
    frontalArea: f64[i + 3],
    centroid: [f64[i + 4], f64[i + 5], f64[i + 6]],
    inertia: Array.from(f64.subarray(i + 7, i + 16)),
  };
}

/** An opened asset. Not thread-shared: one Asset is one C workspace. */
class Asset {
  #mod;
  #asset = 0;
  #ws = 0;
  #data = 0;
  #scratch = 0;
  #fieldIndex = new Map();
  #fieldInfo = [];
  #vertexCounts = new Map(); // element -> { v, t } seen by eval/grad (vjp's input lengths)
  #token = {};
  #ids = 0; // heap block for evalSubset's id lists (grown, never shrunk; freed by close())
  #idsCap = 0; // its size in uint32
  #held = null; // what the finalizer frees

  constructor(mod, u8) {
    this.#mod = mod;
    const m = mod;
    const data = m._malloc(Math.max(u8.length, 1));
    if (!data) throw new CadinterpError(E_OUT_OF_MEMORY, `cannot allocate ${u8.length} bytes for the asset`);
    m.HEAPU8.set(u8, data);
    const out = m._malloc(8);
    if (!out) {
      m._free(data);
      throw new CadinterpError(E_OUT_OF_MEMORY, 'cannot allocate');
    }
    let st = m._cadinterp_open_memory(data, u8.length, 0, out);
    if (st !== 0) {
      const msg = m.UTF8ToString(m._cadinterp_open_error());
      m._free(out);
      m._free(data);
      throw new CadinterpError(st, msg);
    }
    const asset = m.HEAPU32[out >> 2];
    st = m._cadinterp_workspace_create(asset, out);
    const ws = m.HEAPU32[out >> 2];
    m._free(out);
    if (st !== 0) {
      m._cadinterp_close(asset);
      m._free(data);
      throw new CadinterpError(st, 'cannot create a workspace');
    }
    this.#asset = asset;
    this.#ws = ws;
    this.#data = data;

    /** Number of parameters K. */
    this.dim = m._cadinterp_parameter_count(asset);
    /** Basis degree: 1 (linear) or 3 (cubic). */
    this.degree = m._cadinterp_degree(asset);
    /** Elements of the K-d tree. */
    this.elementCount = m._cadinterp_element_count(asset);
    const nf = m._cadinterp_field_count(asset);
    const scratch = m._malloc(S_FIELDS + 8 * Math.max(nf, 1) + 64);
    if (!scratch) {
      this.#release();
      throw new CadinterpError(E_OUT_OF_MEMORY, 'cannot allocate the scratch block');
    }
    this.#scratch = scratch;
    const info = scratch + S_OUT;
    const str = (p) => (p ? m.UTF8ToString(p) : '');
    try {
      const params = [];
      for (let i = 0; i < this.dim; ++i) {
        this.#check(m._cadinterp_parameter(asset, i, info), null);
        const f64 = m.HEAPF64;
        params.push({
          name: str(m.HEAPU32[info >> 2]),
          unit: str(m.HEAPU32[(info >> 2) + 1]),
          lower: f64[(info + 8) >> 3],
          upper: f64[(info + 16) >> 3],
        });
      }
      /** [{ name, unit, lower, upper }] */
      this.parameters = params;
      const fields = [];
      for (let i = 0; i < nf; ++i) {
        this.#check(m._cadinterp_field(asset, i, info), null);
        const u32 = m.HEAPU32;
        const f = {
          name: str(u32[info >> 2]),
          location: u32[(info >> 2) + 1] === 1 ? 'tet' : 'vertex',
          components: m.HEAP32[(info >> 2) + 2],
          maxAbsError: m.HEAPF64[(info + 16) >> 3],
        };
        // A separate call (cadinterp_field_info's layout is ABI): "" when the asset has none.
        this.#check(m._cadinterp_field_unit(asset, i, info), null);
        f.unit = str(m.HEAPU32[info >> 2]);
        fields.push(f);
        if (!this.#fieldIndex.has(f.name)) this.#fieldIndex.set(f.name, i);
      }
      this.#fieldInfo = fields;
      /** [{ name, location: 'vertex'|'tet', components, maxAbsError, unit }] */
      this.fields = fields;
      const regions = [];
      const nr = m._cadinterp_region_count(asset);
      for (let i = 0; i < nr; ++i) {
        this.#check(m._cadinterp_region(asset, i, info), null);
        const u32 = m.HEAPU32;
        const tags = u32[(info >> 2) + 2];
        const n = m.HEAP32[(info >> 2) + 3];
        regions.push({
          name: str(u32[info >> 2]),
          kind: str(u32[(info >> 2) + 1]),
          faceTags: n > 0 ? m.HEAP32.slice(tags >> 2, (tags >> 2) + n) : new Int32Array(0),
        });
      }
      /** [{ name, kind, faceTags: Int32Array }] */
      this.regions = regions;
      const infeasible = [];
      const ni = m._cadinterp_infeasible_point_count(asset);
      const px = scratch + S_X;
      const pmsg = scratch + S_MISC;
      for (let i = 0; i < ni; ++i) {
        this.#check(m._cadinterp_infeasible_point(asset, i, px, pmsg), null);
        infeasible.push({
          x: m.HEAPF64.slice(px >> 3, (px >> 3) + this.dim),
          message: str(m.HEAPU32[pmsg >> 2]),
        });
      }
      /** [{ x: Float64Array, message }] where the builder's host failed. */
      this.infeasiblePoints = infeasible;
      this.#check(m._cadinterp_asset_provenance(asset, info), null);
      const u32 = m.HEAPU32;
      /** { builderVersion, host, options (JSON text) } */
      this.provenance = {
        builderVersion: str(u32[info >> 2]),
        host: str(u32[(info >> 2) + 1]),
        options: str(u32[(info >> 2) + 2]),
      };
    } catch (e) {
      this.#release();
      throw e;
    }
    // Mutable: evalSubset's id block is recorded here when it is (re)allocated.
    this.#held = { mod: m, ws, asset, data, scratch, ids: 0 };
    finalizer?.register(this, this.#held, this.#token);
  }

  // Throws the CadinterpError of a failed call (message from the workspace, or `what`).
  #check(st, what) {
    if (st === 0) return;
    const msg = what ?? (this.#ws ? this.#mod.UTF8ToString(this.#mod._cadinterp_workspace_error(this.#ws)) : '');
    throw new CadinterpError(st, msg);
  }

  #live(name) {
    if (!this.#asset) throw new CadinterpError(E_INVALID_ARGUMENT, `${name}: the asset is closed`);
  }

  // Writes x (K numbers) to the scratch block; returns its address.
  #putX(x, name) {
    this.#live(name);
    if (x == null || typeof x.length !== 'number' || x.length !== this.dim) {
      throw new CadinterpError(E_INVALID_ARGUMENT, `${name}: x must hold ${this.dim} numbers`);
    }
    const p = this.#scratch + S_X;
    const f64 = this.#mod.HEAPF64;
    for (let i = 0; i < this.dim; ++i) {
      const v = x[i];
      if (typeof v !== 'number') throw new CadinterpError(E_INVALID_ARGUMENT, `${name}: x[${i}] is not a number`);
      f64[(p >> 3) + i] = v; // NaN and infinities go through: the runtime reports them
    }
    return p;
  }

  // Field names -> indices in the scratch block; undefined/null: every field.
  #putFields(names, name) {
    let idx;
    if (names == null) {
      idx = this.#fieldInfo.map((_, i) => i);
    } else {
      if (typeof names === 'string' || typeof names.length !== 'number') {
        throw new CadinterpError(E_INVALID_ARGUMENT, `${name}: fields must be an array of field names`);
      }
      idx = Array.from(names, (n) => {
        const i = this.#fieldIndex.get(n);
        if (i === undefined) throw new CadinterpError(E_NOT_FOUND, `${name}: no field named ${JSON.stringify(n)}`);
        return i;
      });
      // The scratch block has one slot per field (a name given twice is the only way past it).
      if (idx.length > this.#fieldInfo.length) {
        throw new CadinterpError(E_INVALID_ARGUMENT, `${name}: more field names than fields (${this.#fieldInfo.length})`);
      }
    }
    const p = this.#scratch + S_FIELDS;
    this.#mod.HEAP32.set(idx, p >> 2);
    return { p, idx };
  }

  #fieldLength(i, v, t) {
    const f = this.#fieldInfo[i];
    return (f.location === 'tet' ? t : v) * f.components;
  }

  /**
   * The element holding x and whether eval succeeds there.
   * @returns {{element: number, feasible: boolean}}
   */
  locate(x) {
    const px = this.#putX(x, 'locate');
    const pe = this.#scratch + S_MISC;
    this.#check(this.#mod._cadinterp_locate(this.#asset, px, pe, pe + 4), null);
    return { element: this.#mod.HEAP32[pe >> 2], feasible: this.#mod.HEAP32[(pe >> 2) + 1] !== 0 };
  }

  /** The estimated geometric error at x, relative to the bbox diagonal (negative: not measured;
   *  throws CadinterpError INFEASIBLE in an infeasible element). cadinterp_error_estimate. */
  errorEstimate(x) {
    const px = this.#putX(x, 'errorEstimate');
    const pd = this.#scratch + S_MISC + 8;
    this.#check(this.#mod._cadinterp_error_estimate(this.#asset, px, pd), null);
    return this.#mod.HEAPF64[pd >> 3];
  }

  /** Byte budget of the decoded-element cache (default 256 MiB). */
  setCacheBudget(bytes) {
    this.#live('setCacheBudget');
    if (typeof bytes !== 'number' || !(bytes >= 0)) {
      throw new CadinterpError(E_INVALID_ARGUMENT, 'setCacheBudget: bytes must be a non-negative number');
    }
    // size_t is 32 bits here: larger budgets mean "everything", as they would natively.
    const b = Math.min(Math.floor(bytes), 0xffffffff);
    this.#check(this.#mod._cadinterp_set_cache_budget(this.#asset, b), null);
  }

  /**
   * The mesh and fields at x (paper Eq. 3). Arrays are views of WebAssembly memory valid until
   * the next call on this asset, unless opts.copy.
   */
  eval(x, fieldNames, opts = {}) {
    const m = this.#mod;
    const px = this.#putX(x, 'eval');
    const { p: pf, idx } = this.#putFields(fieldNames, 'eval');
    const out = this.#scratch + S_OUT;
    this.#check(m._cadinterp_eval(this.#ws, px, pf, idx.length, out), null);
    return this.#readMesh(out, idx, opts, null);
  }

  /**
   * The cadinterp_mesh at `out` as JS: views of the heap (copies with opts.copy). `rows`: the
   * rows of positions and fields, {v, t} from evalSubset; null for the whole mesh's #V and #T.
   */
  #readMesh(out, idx, opts, rows) {
    const m = this.#mod;
    const u32 = m.HEAPU32;
    const o = out >> 2;
    const element = m.HEAP32[o];
    const v = u32[o + 1], t = u32[o + 2], f = u32[o + 3];
    this.#vertexCounts.set(element, { v, t });
    const rv = rows ? rows.v : v, rt = rows ? rows.t : t;
    const buf = m.HEAPU8.buffer;
    const copy = !!opts?.copy;
    const view = (Type, p, n) => (copy ? new Type(buf, p, n).slice() : new Type(buf, p, n));
    const fields = {};
    const fp = u32[o + 8] >> 2;
    idx.forEach((fi, k) => {
      fields[this.#fieldInfo[fi].name] = view(Float32Array, u32[fp + k], this.#fieldLength(fi, rv, rt));
    });
    return {
      element,
      vertexCount: v,
      tetCount: t,
      triangleCount: f,
      positions: view(Float32Array, u32[o + 7], 3 * rv),
      tets: view(Uint32Array, u32[o + 4], 4 * t),
      triangles: view(Uint32Array, u32[o + 5], 3 * f),
      triangleTags: view(Int32Array, u32[o + 6], f),
      fields,
    };
  }

  /**
   * eval at x restricted to chosen vertices and tets (cadinterp_eval_subset): positions (and
   * per-vertex fields) of `vertices` only, per-tet fields of `tets` only, row i for id i of the
   * list; the topology and counts are the whole mesh's, as from eval. For viewers that draw the
   * boundary: the blend then touches a fraction of the mesh. Ids are checked against the element
   * holding x (CADINTERP_E_INVALID_ARGUMENT names the first bad one).
   * @param {{vertices?: Uint32Array|number[], tets?: Uint32Array|number[]}} subset
   */
  evalSubset(x, subset, fieldNames, opts = {}) {
    const m = this.#mod;
    const px = this.#putX(x, 'evalSubset');
    const { p: pf, idx } = this.#putFields(fieldNames, 'evalSubset');
    const vs = subset?.vertices ?? [], ts = subset?.tets ?? [];
    for (const [what, a] of [['vertices', vs], ['tets', ts]]) {
      if (a == null || typeof a.length !== 'number') {
        throw new CadinterpError(E_INVALID_ARGUMENT, `evalSubset: subset.${what} must be an array of ids`);
      }
    }
    const nv = vs.length, nt = ts.length;
    if (nv + nt > this.#idsCap) {
      // Views of this heap (an earlier result passed back as ids) would be detached if the
      // allocation grows the memory: copied out first.
      const keep = (a) => (a.buffer === m.HEAPU8.buffer ? a.slice() : a);
      const v2 = keep(vs), t2 = keep(ts);
      if (this.#ids) m._free(this.#ids);
      this.#ids = 0;
      this.#idsCap = 0;
      if (this.#held) this.#held.ids = 0;
      const cap = Math.max(nv + nt, Math.ceil(1.25 * (nv + nt)), 16);
      const p = m._malloc(4 * cap);
      if (!p) throw new CadinterpError(E_OUT_OF_MEMORY, `evalSubset: cannot allocate ${cap} ids`);
      this.#ids = p;
      this.#idsCap = cap;
      if (this.#held) this.#held.ids = p;
      return this.evalSubset(x, { vertices: v2, tets: t2 }, fieldNames, opts);
    }
    const pv = this.#ids, pt = this.#ids + 4 * nv;
    // Non-integers and negatives would wrap silently in a Uint32Array: refused here instead.
    const put = (a, p, what) => {
      if (a instanceof Uint32Array) {
        m.HEAPU32.set(a, p >> 2);
        return;
      }
      const u32 = m.HEAPU32;
      for (let i = 0; i < a.length; ++i) {
        const v = a[i];
        if (!Number.isInteger(v) || v < 0 || v > 0xffffffff) {
          throw new CadinterpError(E_INVALID_ARGUMENT, `evalSubset: subset.${what}[${i}] is not a vertex or tet id: ${v}`);
        }
        u32[(p >> 2) + i] = v;
      }
    };
    put(vs, pv, 'vertices');
    put(ts, pt, 'tets');
    const out = this.#scratch + S_OUT;
    this.#check(m._cadinterp_eval_subset(this.#ws, px, pv, nv, pt, nt, pf, idx.length, out), null);
    return this.#readMesh(out, idx, opts, { v: nv, t: nt });
  }

  /**
   * Positions and their K derivative arrays (and the fields' derivatives) at x (Eq. 13):
   * dpositions[d * 3 * #V + 3 * v + c] = d P_vc / d x_d.
   */
  grad(x, fieldNames, opts = {}) {
    const m = this.#mod;
    let px = this.#putX(x, 'grad');
    let { p: pf, idx } = this.#putFields(fieldNames, 'grad');
    let counts = null;
    if (idx.some((fi) => this.#fieldInfo[fi].location === 'tet')) {
      // Per-tet fields need #T, which cadinterp_mesh_grad does not carry: from an earlier eval
      // of this element, or an eval without fields now.
      counts = this.#countsAt(px);
      px = this.#putX(x, 'grad');
      ({ p: pf, idx } = this.#putFields(fieldNames, 'grad'));
    }
    const out = this.#scratch + S_OUT;
    this.#check(m._cadinterp_grad(this.#ws, px, pf, idx.length, out), null);
    const u32 = m.HEAPU32;
    const o = out >> 2;
    const v = u32[o + 1];
    const t = counts ? counts.t : 0;
    const buf = m.HEAPU8.buffer;
    const copy = !!opts?.copy;
    const view = (Type, p, n) => (copy ? new Type(buf, p, n).slice() : new Type(buf, p, n));
    const K = this.dim;
    const dfields = {};
    const fp = u32[o + 4] >> 2;
    idx.forEach((fi, k) => {
      dfields[this.#fieldInfo[fi].name] = view(Float32Array, u32[fp + k], K * this.#fieldLength(fi, v, t));
    });
    return {
      element: m.HEAP32[o],
      vertexCount: v,
      positions: view(Float32Array, u32[o + 2], 3 * v),
      dpositions: view(Float32Array, u32[o + 3], K * 3 * v),
      dfields,
    };
  }

  // { v: #V, t: #T } of the element holding x (already in the scratch block at px): from an
  // earlier eval of that element, else from an eval without fields (which overwrites the
  // workspace's arrays and the scratch block's field list: callers rewrite their inputs).
  #countsAt(px) {
    const m = this.#mod;
    const pe = this.#scratch + S_MISC;
    this.#check(m._cadinterp_locate(this.#asset, px, pe, pe + 4), null);
    const known = this.#vertexCounts.get(m.HEAP32[pe >> 2]);
    if (known) return known;
    const out = this.#scratch + S_OUT;
    this.#check(m._cadinterp_eval(this.#ws, px, 0, 0, out), null);
    const o = out >> 2;
    const counts = { v: m.HEAPU32[o + 1], t: m.HEAPU32[o + 2] };
    this.#vertexCounts.set(m.HEAP32[o], counts);
    return counts;
  }

  /**
   * Vector-Jacobian product: dF/dx (Float64Array of K) from dF/dpositions (#V*3 or null) and
   * optional field adjoints { name: Float32Array }.
   */
  vjp(x, dPositions, fieldAdjoints) {
    const m = this.#mod;
    const px = this.#putX(x, 'vjp');
    const names = fieldAdjoints == null ? [] : Object.keys(fieldAdjoints);
    const { p: pf, idx } = this.#putFields(names, 'vjp');
    // The C ABI reads #V*3 (and #V or #T per field) values without lengths: check them against
    // the element's counts.
    const counts = this.#countsAt(px);
    this.#putFields(names, 'vjp');
    const arrays = [];
    const want = [];
    if (dPositions != null) {
      arrays.push(dPositions);
      want.push(['dPositions', 3 * counts.v]);
    }
    idx.forEach((fi, k) => {
      arrays.push(fieldAdjoints[names[k]]);
      want.push([`adjoint of ${names[k]}`, this.#fieldLength(fi, counts.v, counts.t)]);
    });
    for (let k = 0; k < arrays.length; ++k) {
      const a = arrays[k];
      if (a != null && (typeof a.length !== 'number' || a.length !== want[k][1])) {
        throw new CadinterpError(E_INVALID_ARGUMENT, `vjp: ${want[k][0]} must hold ${want[k][1]} values`);
      }
    }
    // Views of this heap (say, the positions of an eval used as an adjoint) would be detached
    // if the allocations below grow the memory: copied out first.
    for (let k = 0; k < arrays.length; ++k) {
      if (arrays[k]?.buffer === m.HEAPU8.buffer) arrays[k] = arrays[k].slice();
    }
    const ptrs = [];
    try {
      for (const a of arrays) {
        if (a == null) {
          ptrs.push(0);
          continue;
        }
        const p = m._malloc(Math.max(4 * a.length, 4));
        if (!p) throw new CadinterpError(E_OUT_OF_MEMORY, 'vjp: cannot allocate the adjoints');
        ptrs.push(p);
        m.HEAPF32.set(a, p >> 2);
      }
      const pPos = dPositions != null ? ptrs[0] : 0;
      const fieldPtrs = dPositions != null ? ptrs.slice(1) : ptrs;
      const pAdj = pf + 4 * Math.max(this.#fieldInfo.length, 1);
      m.HEAPU32.set(fieldPtrs, pAdj >> 2);
      const pdx = this.#scratch + S_DX;
      this.#check(m._cadinterp_vjp(this.#ws, px, pPos, pf, idx.length ? pAdj : 0, idx.length, pdx), null);
      return m.HEAPF64.slice(pdx >> 3, (pdx >> 3) + this.dim);
    } finally {
      for (const p of ptrs) if (p) m._free(p);
    }
  }

  /**
   * Mass properties of the solid at x; opts: { density = 1, direction = [0, 0, 1], grad = false }.
   * With grad, .grad holds K objects of the same keys: the derivatives along x_d.
   */
  properties(x, opts = {}) {
    const m = this.#mod;
    const px = this.#putX(x, 'properties');
    const density = opts?.density ?? 1;
    const dir = opts?.direction ?? [0, 0, 1];
    if (typeof density !== 'number') throw new CadinterpError(E_INVALID_ARGUMENT, 'properties: density must be a number');
    if (dir == null || dir.length !== 3 || !Array.from(dir).every((d) => typeof d === 'number')) {
      throw new CadinterpError(E_INVALID_ARGUMENT, 'properties: direction must hold 3 numbers');
    }
    const pdir = this.#scratch + S_DIR;
    m.HEAPF64.set(Array.from(dir), pdir >> 3);
    const out = this.#scratch + S_OUT;
    const pg = opts?.grad ? this.#scratch + S_PGRAD : 0;
    this.#check(m._cadinterp_eval_properties(this.#ws, px, density, pdir, out, pg), null);
    const f64 = m.HEAPF64;
    const r = readProps(f64, out);
    if (pg) {
      r.grad = [];
      for (let d = 0; d < this.dim; ++d) r.grad.push(readProps(f64, pg + d * PROPS_SIZE));
    }
    return r;
  }

  #release() {
    const m = this.#mod;
    if (this.#ws) m._cadinterp_workspace_destroy(this.#ws);
    if (this.#asset) m._cadinterp_close(this.#asset);
    if (this.#data) m._free(this.#data);
    if (this.#scratch) m._free(this.#scratch);
    if (this.#ids) m._free(this.#ids);
    this.#ws = this.#asset = this.#data = this.#scratch = this.#ids = this.#idsCap = 0;
  }

  /** Frees the asset's memory. Idempotent; any later call throws CADINTERP_E_INVALID_ARGUMENT. */
  close() {
    if (!this.#asset) return;
    finalizer?.unregister(this.#token);
    this.#release();
    this.#vertexCounts.clear();
  }
}
