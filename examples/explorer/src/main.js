// The explorer page: evaluates a cadinterp asset in the browser (WebAssembly runtime) while the
// user drags a slider per parameter, and draws the part, a field, its boundary conditions and
// its mass properties. The main thread evaluates the interpolated mesh (paper Eq. 3) at most
// once per animation frame and draws it; the mass properties, an integral over every tet, are
// computed by a worker with its own runtime instance (src/properties-worker.js) for the latest x
// and shown as they arrive, so a large mesh does not halve the frame rate.
//
// Served by `cadinterp explore ASSET`: the asset comes from api/asset.cadi, the runtime from
// wasm/ (the page's own directory otherwise; ?asset=URL and ?wasm=DIR override both).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { Surface, fieldMax, fieldRange, infeasibleRuns, propertiesAndRanges } from './surface.js';
import { colorize, cssColor } from './colormap.js';
import { OptimizePanel } from './optimize-panel.js';

// The test hook (scripts/test-explorer.sh drives the page through it; harmless otherwise).
const hook = { ready: false, error: null };
window.__explorer = hook;

const STRESS_NAME = /stress|mises|tresca|sigma/i;
// Drawing while a slider moves: at most this many triangles (software GL, e.g. SwiftShader in
// headless Chromium, drew the 32k-triangle bracket at ~22 fps and a quarter of it at ~55), and
// the full surface again this long after the last update (what the user then looks at).
const LOD_TRIANGLES = 8000;
const LOD_PAUSE_MS = 150;
// The host's applied surface traction (per vertex, 3 components, zero off loaded faces): force
// arrows follow it, so that a load-direction parameter turns them (examples/hosts/occt).
const TRACTION_FIELD = 'traction';

/** " [unit]" for a field with a unit, "" without (format 1.0 assets have none). */
function unitSuffix(f) {
  return f?.unit ? ` [${f.unit}]` : '';
}

function fmt(v, digits = 4) {
  if (v === null || v === undefined || Number.isNaN(v)) return '–';
  if (!Number.isFinite(v)) return String(v);
  const a = Math.abs(v);
  if (a !== 0 && (a >= 1e6 || a < 1e-3)) return v.toExponential(digits - 1);
  return Number(v.toPrecision(digits)).toString();
}

/** [min, max] of the first n values (NaN-free: per-vertex means). */
function surfaceRange(v, n) {
  let lo = Infinity, hi = -Infinity;
  for (let i = 0; i < n; ++i) {
    const a = v[i];
    lo = a < lo ? a : lo;
    hi = a > hi ? a : hi;
  }
  return n ? [lo, hi] : [0, 1];
}

/** Whether WebGL runs on a software rasterizer (SwiftShader, llvmpipe). */
function softwareGL() {
  try {
    const gl = document.createElement('canvas').getContext('webgl2') ?? document.createElement('canvas').getContext('webgl');
    const ext = gl?.getExtension('WEBGL_debug_renderer_info');
    const name = ext ? gl.getParameter(ext.UNMASKED_RENDERER_WEBGL) : '';
    gl?.getExtension('WEBGL_lose_context')?.loseContext();
    return /swiftshader|llvmpipe|software/i.test(name);
  } catch {
    return false;
  }
}

class Explorer {
  constructor(lib, asset, info) {
    this.lib = lib;
    this.asset = asset;
    this.info = info;
    this.params = asset.parameters;
    this.fields = asset.fields;
    this.regions = asset.regions;
    this.K = asset.dim;
    this.x = new Float64Array(this.K);
    this.evaluatedX = null; // x of the shape on screen
    this.infeasible = false;
    this.message = '';
    this.pending = true;
    this.surface = new Surface();
    this.capV = 0;
    this.capI = 0;
    this.readout = {}; // from the mesh on screen (field ranges, max stress, counts, error estimate)
    this.props = null; // mass properties, and the request they answer
    this.propsFor = null;
    this.propsWanted = null;
    this.propsBusy = false;
    this.propsError = '';
    this.propsSerial = 0;
    this.stats = { updates: 0, lastUpdateMs: 0, evalMs: 0, propsMs: 0 };
    this.useSubset = new URLSearchParams(location.search).get('subset') !== '0';
    this.lod = new URLSearchParams(location.search).get('lod') !== '0';
    this.coarseShown = false;
    this.fullRanges = {}; // field name -> [min, max] over the whole mesh, latest known (worker)
    const pi = Number(new URLSearchParams(location.search).get('propsms'));
    // ?propsms=N: at most one properties request per N ms (default 100: ~6 answers a second
    // while dragging, measured 15 -> 18-21 fps on the 90k bracket on 2 shared cores; at rest the
    // answer for the shape on screen follows within one interval).
    this.propsIntervalMs = pi > 0 || new URLSearchParams(location.search).get('propsms') === '0' ? pi : 100;
    this.propsTimer = null;
    this.rateWindow = [];
    this.markKeys = new Array(this.K).fill('');
    this.colorRange = null;
    this.viewFitted = false;
  }

  // ---- set-up ---------------------------------------------------------------------------------

  start() {
    document.getElementById('asset-name').textContent =
      `${this.info.name ?? 'asset'} · ${this.K} parameters · ${this.asset.elementCount} elements · degree ${this.asset.degree}`;
    this.buildSliders();
    this.buildFieldControls();
    this.buildScene();
    this.buildBoundaryLegend();
    this.x.set(this.initialPoint());
    this.syncSliders();
    this.update();
    this.loop();
    this.optimizer = new OptimizePanel(this);
    this.installHook();
    this.optimizer.probe();
  }

  /** Moves every slider to x (the Optimize panel's iterates); drawn on the next frame. */
  moveTo(x) {
    this.x.set(x);
    this.syncSliders();
    this.pending = true;
  }

  /** The box centre, or when that is infeasible (an infeasible element may hold it: points on
   *  an element face belong to the upper side) the feasible grid point nearest to it. */
  initialPoint() {
    const centre = this.params.map((p) => 0.5 * (p.lower + p.upper));
    if (this.asset.locate(centre).feasible) return centre;
    // The finest grid of at most ~5000 points, nearest points first.
    let n = 2;
    while ((n + 2) ** this.K <= 5000) n += 1;
    const total = (n + 1) ** this.K;
    const points = [];
    for (let c = 0; c < total; ++c) {
      let r = c, d2 = 0;
      const q = new Array(this.K);
      for (let d = 0; d < this.K; ++d) {
        const u = (r % (n + 1)) / n;
        const p = this.params[d];
        q[d] = p.lower + u * (p.upper - p.lower);
        d2 += (u - 0.5) ** 2;
        r = Math.floor(r / (n + 1));
      }
      points.push([d2, q]);
    }
    points.sort((a, b) => a[0] - b[0]);
    for (const [, q] of points) if (this.asset.locate(q).feasible) return q;
    throw new Error(`the asset has no feasible point on a grid of ${n + 1} points per parameter`);
  }

  buildSliders() {
    const box = document.getElementById('sliders');
    this.sliders = this.params.map((p, i) => {
      const el = document.createElement('div');
      el.className = 'slider';
      el.innerHTML = `
        <div class="label"><span class="name"></span><span class="value"></span></div>
        <div class="range"><div class="track"><div class="marks"></div></div><input type="range"></div>`;
      el.querySelector('.name').textContent = p.unit ? `${p.name} [${p.unit}]` : p.name;
      const input = el.querySelector('input');
      input.min = String(p.lower);
      input.max = String(p.upper);
      input.step = 'any';
      input.setAttribute('aria-label', p.name);
      input.dataset.index = String(i);
      input.addEventListener('input', () => {
        this.x[i] = Number(input.value);
        this.sliders[i].value.textContent = fmt(this.x[i], 5);
        this.pending = true;
        this.optimizer?.showFixedValues();
      });
      box.appendChild(el);
      return { el, input, value: el.querySelector('.value'), marks: el.querySelector('.marks'), runs: [] };
    });
  }

  syncSliders() {
    this.sliders.forEach((s, i) => {
      s.input.value = String(this.x[i]);
      s.value.textContent = fmt(this.x[i], 5);
    });
    this.optimizer?.showFixedValues();
  }

  buildFieldControls() {
    const sel = document.getElementById('field-select');
    const none = new Option('(none: plain)', '');
    sel.add(none);
    for (const f of this.fields) {
      const what = f.components > 1 ? `|${f.name}| (${f.components}-vector)` : f.name;
      sel.add(new Option(`${what}${unitSuffix(f)} (per ${f.location})`, f.name));
    }
    const stressFields = this.fields.filter((f) => STRESS_NAME.test(f.name));
    // Default display: a stress field if there is one (what the engineer looks at first).
    this.displayField = (stressFields[0] ?? this.fields[0])?.name ?? '';
    sel.value = this.displayField;
    sel.addEventListener('change', () => {
      this.displayField = sel.value;
      this.colorRange = null;
      this.pending = true;
    });
    const ssel = document.getElementById('stress-select');
    const candidates = stressFields.length ? stressFields : this.fields;
    if (!candidates.length) ssel.add(new Option('(no fields)', ''));
    for (const f of candidates) ssel.add(new Option(`${f.name}${unitSuffix(f)}`, f.name));
    this.stressField = candidates[0]?.name ?? '';
    ssel.value = this.stressField;
    ssel.addEventListener('change', () => {
      this.stressField = ssel.value;
      this.pending = true;
    });
    this.lockRange = document.getElementById('lock-range');
    this.lockRange.addEventListener('change', () => (this.pending = true));
    this.densityInput = document.getElementById('density');
    this.densityInput.addEventListener('input', () => this.requestProperties());
    this.directionSelect = document.getElementById('direction');
    this.directionSelect.addEventListener('change', () => this.requestProperties());
  }

  buildScene() {
    const view = document.getElementById('view');
    // Multisampling costs most of a frame in software GL (SwiftShader, e.g. headless or no GPU
    // driver): off there, on elsewhere; ?aa=0|1 overrides.
    const aa = new URLSearchParams(location.search).get('aa');
    this.renderer = new THREE.WebGLRenderer({ antialias: aa === null ? !softwareGL() : aa === '1' });
    this.renderer.setPixelRatio(window.devicePixelRatio);
    this.renderer.setClearColor(0xeef0f3);
    view.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.1, 1e6);
    this.camera.up.set(0, 1, 0);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => (this.needsRender = true));
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8090a0, 1.6));
    this.light = new THREE.DirectionalLight(0xffffff, 1.6);
    this.camera.add(this.light);
    this.light.position.set(0.5, 1, 1);
    this.scene.add(this.camera);

    this.material = new THREE.MeshLambertMaterial({ vertexColors: true });
    // Fixed regions: screen-space hatching drawn over the part (polygon offset keeps it in
    // front of the coincident part surface).
    this.hatchMaterial = new THREE.ShaderMaterial({
      uniforms: { color: { value: new THREE.Color(0x2f3b52) } },
      vertexShader: 'void main() { gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0); }',
      fragmentShader: `uniform vec3 color;
        void main() {
          if (mod(gl_FragCoord.x + gl_FragCoord.y, 9.0) > 3.5) discard;
          gl_FragColor = vec4(color, 1.0);
        }`,
      polygonOffset: true,
      polygonOffsetFactor: -2,
      polygonOffsetUnits: -2,
    });
    this.arrows = [];
    const resize = () => {
      const w = view.clientWidth, h = view.clientHeight;
      this.renderer.setSize(w, h);
      this.camera.aspect = w / Math.max(1, h);
      this.camera.updateProjectionMatrix();
      this.needsRender = true;
    };
    window.addEventListener('resize', resize);
    // The camera stays where the user put it while sliders move (a view that jumps while
    // dragging is hard to read); "fit view" or the F key frames the current part.
    const fit = document.createElement('button');
    fit.id = 'fit';
    fit.textContent = 'fit view';
    fit.title = 'frame the part (F)';
    fit.addEventListener('click', () => this.refit());
    view.appendChild(fit);
    window.addEventListener('keydown', (e) => {
      if ((e.key === 'f' || e.key === 'F') && e.target === document.body) this.refit();
    });
    resize();
  }

  buildBoundaryLegend() {
    const box = document.getElementById('bc-legend');
    this.fixedTags = this.regions.filter((r) => r.kind === 'fixed').flatMap((r) => Array.from(r.faceTags));
    this.forceRegions = this.regions.filter((r) => r.kind === 'force');
    this.tractionField = this.fields.find((f) => f.name === TRACTION_FIELD && f.location === 'vertex' && f.components === 3) ?? null;
    const along = this.tractionField
      ? 'arrow to its centroid, along the applied load (mean traction over its faces)'
      : 'arrow to its centroid, along its mean inward normal (the asset has no traction field)';
    const lines = this.regions.map((r) => {
      const cls = r.kind === 'fixed' ? 'fixed' : r.kind === 'force' ? 'force' : '';
      const how = r.kind === 'fixed' ? 'hatched' : r.kind === 'force' ? along : 'not drawn';
      return `<div><span class="swatch ${cls}"></span><b></b> (${r.kind || 'no kind'}; faces ${Array.from(r.faceTags).join(', ')}): ${how}<span class="load"></span></div>`;
    });
    box.innerHTML = lines.join('') || 'none in this asset';
    box.querySelectorAll('b').forEach((b, i) => (b.textContent = this.regions[i].name));
    const rows = box.querySelectorAll(':scope > div');
    this.loadLabels = this.forceRegions.map((r) => {
      const row = rows[this.regions.indexOf(r)];
      return { row, span: row.querySelector('.load') };
    });
    this.loads = this.forceRegions.map(() => null);
    this.arrows = this.forceRegions.map(() => {
      const a = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 1, 0xe4572e);
      a.visible = false;
      this.scene.add(a);
      return a;
    });
  }

  // ---- geometry buffers (reused; reallocated only when a topology outgrows them) ------------

  ensureCapacity(nv, ni) {
    if (this.mesh && nv <= this.capV && ni <= this.capI) return;
    const capV = Math.max(nv, Math.ceil(this.capV * 1.5));
    const capI = Math.max(ni, Math.ceil(this.capI * 1.5));
    if (this.mesh) {
      this.scene.remove(this.mesh, this.overlay);
      this.mesh.geometry.dispose();
      this.overlay.geometry.dispose();
    }
    const g = new THREE.BufferGeometry();
    const attr = (n) => new THREE.BufferAttribute(new Float32Array(3 * n), 3).setUsage(THREE.DynamicDrawUsage);
    this.position = attr(capV);
    this.normal = attr(capV);
    this.color = attr(capV);
    this.scalar = new Float32Array(capV);
    g.setAttribute('position', this.position);
    g.setAttribute('normal', this.normal);
    g.setAttribute('color', this.color);
    this.fullIndex = new THREE.BufferAttribute(new Uint32Array(capI), 1);
    g.setIndex(this.fullIndex);
    this.mesh = new THREE.Mesh(g, this.material);
    this.mesh.frustumCulled = false; // positions move every frame; the bound would go stale
    const og = new THREE.BufferGeometry();
    og.setAttribute('position', this.position); // shared: uploaded once per frame
    og.setIndex(new THREE.BufferAttribute(new Uint32Array(Math.max(3, capI)), 1));
    this.overlay = new THREE.Mesh(og, this.hatchMaterial);
    this.overlay.frustumCulled = false;
    this.scene.add(this.mesh, this.overlay);
    this.capV = capV;
    this.capI = capI;
  }

  adoptTopology() {
    const s = this.surface;
    this.ensureCapacity(s.surfaceVertexCount, s.index.length);
    const g = this.mesh.geometry;
    g.setIndex(this.fullIndex);
    this.coarseShown = false;
    this.coarseAttr = null;
    g.index.array.set(s.index);
    g.index.clearUpdateRanges?.();
    g.index.needsUpdate = true;
    g.setDrawRange(0, s.index.length);
    const fixed = s.regionIndex(this.fixedTags);
    const og = this.overlay.geometry;
    og.index.array.set(fixed);
    og.index.needsUpdate = true;
    og.setDrawRange(0, fixed.length);
  }

  // ---- level of detail while dragging -------------------------------------------------------

  /** While updates follow each other (a drag), the coarse surface (Surface.coarseIndex) is
   *  drawn; LOD_PAUSE_MS after the last update the full one is again. Off with ?lod=0, and for
   *  surfaces of at most LOD_TRIANGLES triangles. */
  showDragDetail() {
    if (!this.lod) return;
    const s = this.surface;
    const coarse = s.coarseIndex(this.position.array, this.normal.array, LOD_TRIANGLES);
    if (!coarse) return;
    if (!this.coarseAttr || this.coarseAttr.array !== coarse) this.coarseAttr = new THREE.BufferAttribute(coarse, 1);
    if (!this.coarseShown) {
      this.mesh.geometry.setIndex(this.coarseAttr);
      this.mesh.geometry.setDrawRange(0, coarse.length);
      this.coarseShown = true;
    }
    clearTimeout(this.lodTimer);
    this.lodTimer = setTimeout(() => this.showFullDetail(), LOD_PAUSE_MS);
  }

  showFullDetail() {
    clearTimeout(this.lodTimer);
    if (!this.coarseShown) return;
    this.mesh.geometry.setIndex(this.fullIndex);
    this.mesh.geometry.setDrawRange(0, this.surface.index.length);
    this.coarseShown = false;
    this.needsRender = true;
  }

  // ---- evaluation ------------------------------------------------------------------------------

  density() {
    const d = Number(this.densityInput.value);
    return Number.isFinite(d) && d >= 0 ? d : 1;
  }

  direction() {
    return this.directionSelect.value.split(',').map(Number);
  }

  /** Evaluates at this.x and updates the picture and the readouts; infeasible x keep the last
   *  feasible shape on screen with a message, and are never evaluated. */
  update() {
    this.pending = false;
    const t0 = performance.now();
    const x = this.x;
    let loc;
    try {
      loc = this.asset.locate(x);
    } catch (e) {
      this.setInfeasible(`cannot evaluate here: ${e.message}`);
      return;
    }
    if (!loc.feasible) {
      this.setInfeasible(this.infeasibleText(loc.element));
      return;
    }
    const names = [...new Set([this.displayField, this.stressField, this.tractionField?.name].filter(Boolean))];
    // Only the drawn surface is evaluated (cadinterp_eval_subset): its vertices and the tets of
    // its triangles, ~1/8 of the blend of the whole mesh on the 90k-vertex bracket. What needs
    // every tet (the colour range, max stress, mass properties) comes from the worker.
    // ?subset=0 evaluates the whole mesh here, as before (for comparison).
    const subset = this.useSubset;
    let m;
    try {
      if (subset) {
        // A new element may bring another topology (mesh mapping, paper §6): learn it from a
        // shape-only eval before asking for rows of it.
        if (this.surface.element !== loc.element || !this.surface.version) {
          // (evalSubset with no rows: the topology without blending anything.)
          if (this.surface.sync(this.asset.evalSubset(x, {}, []))) this.adoptTopology();
        }
        m = this.asset.evalSubset(x, this.surface.subsetIds(), names); // views: read before the next call
      } else {
        m = this.asset.eval(x, names); // views into wasm memory: read before the next call
      }
    } catch (e) {
      // The runtime refuses rather than returning garbage (e.g. a damaged element): say so and
      // keep the last good shape, as for infeasible designs.
      this.setInfeasible(`The runtime could not evaluate this design: ${e.message}${e.statusName ? ` (${e.statusName})` : ''}. Showing the last design it could.`);
      return;
    }
    const tEval = performance.now();
    if (!subset && this.surface.sync(m)) this.adoptTopology();
    const s = this.surface, nv = s.surfaceVertexCount;
    const pos = this.position.array;
    if (subset) pos.set(m.positions);
    else s.gatherPositions(m.positions, pos);
    const tGather = performance.now();
    s.computeNormals(pos, this.normal.array);
    const tNormals = performance.now();
    const r = {};
    const display = this.fields.find((f) => f.name === this.displayField);
    const stress = this.fields.find((f) => f.name === this.stressField);
    if (display) {
      const values = m.fields[display.name];
      if (subset) s.surfaceValues(values, display.location, display.components, this.scalar);
      else s.vertexValues(values, display.location, display.components, this.scalar);
      // The whole field's range: here from the full eval, else the worker's latest for this
      // field (a few frames behind while dragging, exact once its answer for this x arrives:
      // acceptProperties recolours), else until then the drawn values' own range.
      const range = !subset
        ? fieldRange(values, display.components)
        : this.fullRanges[display.name] ?? surfaceRange(this.scalar, nv);
      if (!this.lockRange.checked || !this.colorRange) this.colorRange = range;
      colorize(this.scalar, nv, this.colorRange[0], this.colorRange[1], this.color.array);
      r.fieldMin = range[0];
      r.fieldMax = range[1];
    } else {
      this.color.array.fill(0.72, 0, 3 * nv);
      this.colorRange = null;
    }
    if (!subset) {
      // The displayed field's range already has its max (one pass less over 490k tets).
      r.maxStress = !stress ? NaN : stress === display ? r.fieldMax : fieldMax(m.fields[stress.name], stress.components);
    }
    r.element = m.element;
    r.vertices = m.vertexCount;
    r.tets = m.tetCount;
    r.triangles = m.triangleCount;
    const tColours = performance.now();
    r.errorEstimate = this.asset.errorEstimate(x);
    for (const a of [this.position, this.normal, this.color]) {
      a.clearUpdateRanges?.();
      a.addUpdateRange?.(0, 3 * nv);
      a.needsUpdate = true;
    }
    this.updateLoads(pos, this.tractionField ? m.fields[this.tractionField.name] : null, subset);
    this.updateArrows();
    if (!this.viewFitted) this.fitView(pos, nv);
    this.readout = r;
    this.evaluatedX = Float64Array.from(x);
    this.requestProperties();
    this.infeasible = false;
    this.message = '';
    this.showMessage('');
    this.sliders.forEach((sl) => sl.el.classList.remove('infeasible'));
    document.getElementById('readouts').classList.remove('stale');
    this.renderReadouts();
    this.renderLegend();
    this.needsRender = true;
    this.showDragDetail();
    const t1 = performance.now();
    this.stats.updates += 1;
    this.stats.lastUpdateMs = t1 - t0;
    this.stats.evalMs = tEval - t0;
    this.stats.surfaceMs = tColours - tEval; // topology check, gather, normals, field colours
    this.stats.gatherMs = tGather - tEval;
    this.stats.normalsMs = tNormals - tGather;
    this.stats.coloursMs = tColours - tNormals;
    this.stats.restMs = t1 - tColours; // error estimate, loads, arrows, readouts, legend
    this.rateWindow.push(t1);
  }

  // ---- mass properties (worker, or here when there is none) ----------------------------------

  /** What the properties shown must answer: the shape on screen, the density, the direction,
   *  and (when the page evaluates the surface only) the fields whose whole range it shows. */
  propertiesRequest() {
    const ranges = this.useSubset ? [...new Set([this.displayField, this.stressField].filter(Boolean))] : [];
    return { x: Array.from(this.evaluatedX), density: this.density(), direction: this.direction(), ranges };
  }

  requestProperties() {
    if (!this.evaluatedX) return;
    this.propsWanted = this.propertiesRequest();
    this.pumpProperties();
  }

  pumpProperties() {
    if (this.propsBusy || !this.propsWanted || this.propsTimer) return;
    // At most one request per propsIntervalMs: a worker answering back to back takes a whole
    // core, which on a 2-core machine the drawing and the drag's evaluations need.
    const wait = (this.propsLastSent ?? -Infinity) + this.propsIntervalMs - performance.now();
    if (wait > 0) {
      this.propsTimer = setTimeout(() => {
        this.propsTimer = null;
        this.pumpProperties();
      }, wait);
      return;
    }
    this.propsLastSent = performance.now();
    const req = this.propsWanted;
    this.propsWanted = null;
    if (!this.worker) {
      // No worker (or ?worker=0): on the main thread, after the mesh (whose views this call
      // invalidates: update() has read them all by now).
      const t0 = performance.now();
      try {
        const { properties, ranges } = propertiesAndRanges(this.asset, req);
        this.acceptProperties(req, properties, '', ranges);
      } catch (e) {
        this.acceptProperties(req, null, `${e.message}${e.statusName ? ` (${e.statusName})` : ''}`);
      }
      this.stats.propsMs = performance.now() - t0;
      return;
    }
    this.propsBusy = true;
    req.id = ++this.propsSerial;
    req.sent = performance.now();
    this.propsInFlight = req;
    this.worker.postMessage({ type: 'properties', ...req });
  }

  onWorkerMessage(m) {
    if (m.type !== 'properties') return;
    const req = this.propsInFlight;
    this.propsBusy = false;
    this.stats.propsMs = performance.now() - req.sent;
    this.acceptProperties(req, m.properties, m.error ?? '', m.ranges);
    this.pumpProperties();
  }

  acceptProperties(req, p, error, ranges = {}) {
    this.propsError = error;
    if (!error) {
      this.props = { ...p };
      this.propsFor = { x: req.x, density: req.density, direction: req.direction, ranges: req.ranges };
      this.stats.propsUpdates = (this.stats.propsUpdates ?? 0) + 1;
      Object.assign(this.fullRanges, ranges);
      // The whole mesh's values, for the x these properties answer (as the properties).
      if (ranges[this.stressField]) this.props.maxStress = ranges[this.stressField][1];
      const display = ranges[this.displayField];
      if (display) {
        this.props.fieldMin = display[0];
        this.props.fieldMax = display[1];
      }
      // The answer for the shape on screen: its colours get the exact range (they had the
      // latest range known when it was drawn).
      const onScreen = this.evaluatedX && req.x.every((v, i) => v === this.evaluatedX[i]);
      if (onScreen && display && this.mesh && !this.infeasible && (!this.lockRange.checked || !this.colorRange) &&
          !(this.colorRange && this.colorRange[0] === display[0] && this.colorRange[1] === display[1])) {
        this.colorRange = display;
        const nv = this.surface.surfaceVertexCount;
        colorize(this.scalar, nv, display[0], display[1], this.color.array);
        this.color.clearUpdateRanges?.();
        this.color.addUpdateRange?.(0, 3 * nv);
        this.color.needsUpdate = true;
        this.needsRender = true;
        this.renderLegend();
      }
    }
    this.renderReadouts();
  }

  /** Whether the properties shown answer the current shape, density and direction. */
  propertiesCurrent() {
    if (!this.evaluatedX) return false;
    const want = this.propertiesRequest(), have = this.propsFor;
    return (
      !!have &&
      have.density === want.density &&
      have.ranges.join('\n') === want.ranges.join('\n') &&
      have.direction.every((v, i) => v === want.direction[i]) &&
      have.x.every((v, i) => v === want.x[i])
    );
  }

  infeasibleText(element) {
    // The nearest point where the builder's host failed, by normalized distance, says why.
    let best = null, bestD = Infinity;
    for (const q of this.asset.infeasiblePoints) {
      let d = 0;
      for (let i = 0; i < this.K; ++i) {
        const w = this.params[i].upper - this.params[i].lower || 1;
        d += ((q.x[i] - this.x[i]) / w) ** 2;
      }
      if (d < bestD) [best, bestD] = [q, d];
    }
    const why = best?.message ? ` The host said: “${best.message}”.` : '';
    return `This design is infeasible (element ${element} depends on designs the CAD host could not build).${why} Showing the last feasible design.`;
  }

  setInfeasible(text) {
    this.infeasible = true;
    this.message = text;
    this.showMessage(text);
    document.getElementById('readouts').classList.add('stale');
    this.sliders.forEach((sl, i) => {
      const inRun = sl.runs.some(([a, b]) => this.x[i] >= a && this.x[i] <= b);
      sl.el.classList.toggle('infeasible', inRun);
    });
  }

  showMessage(text) {
    const el = document.getElementById('message');
    el.hidden = !text;
    el.textContent = text;
  }

  /** Each force region's centroid and load on the mesh on screen: the area-weighted mean of the
   *  traction field over the region's faces (the applied load, which a load-direction parameter
   *  turns), or without that field the mean inward normal. */
  updateLoads(pos, traction, compactTraction = false) {
    const unit = this.tractionField?.unit ?? '';
    this.loads = this.forceRegions.map((region, k) => {
      const f = this.surface.regionFrame(pos, region.faceTags, traction, compactTraction);
      const label = this.loadLabels[k];
      if (!f) {
        label.span.textContent = '';
        return null;
      }
      const t = f.meanTraction;
      const mag = t ? Math.hypot(...t) : 0;
      // A region without load at this x (zero traction) falls back to the normal, drawn alike.
      const fromTraction = !!t && mag > 0;
      const dir = fromTraction ? t.map((c) => c / mag) : f.outwardNormal.map((c) => -c);
      const load = { centroid: f.centroid, direction: dir, magnitude: fromTraction ? mag : NaN, traction: t, source: fromTraction ? 'traction' : 'normal' };
      const text = fromTraction
        ? ` — load ${fmt(mag)}${unit ? ` ${unit}` : ''} along (${dir.map((c) => fmt(c, 3)).join(', ')})`
        : '';
      label.span.textContent = text;
      label.row.title = fromTraction
        ? `mean applied traction ${t.map((c) => fmt(c)).join(', ')}${unit ? ` ${unit}` : ''} over ${fmt(f.area)} of area`
        : 'drawn along the mean inward normal';
      return load;
    });
  }

  updateArrows() {
    const diag = this.diagonal ?? 1;
    // The largest load gets 0.18 of the part's diagonal; smaller ones shorter, never below half
    // of it (a tiny arrow is hard to see and its direction is what matters most).
    const big = Math.max(0, ...this.loads.filter(Boolean).map((l) => (Number.isFinite(l.magnitude) ? l.magnitude : 0)));
    this.forceRegions.forEach((region, k) => {
      const l = this.loads[k];
      const a = this.arrows[k];
      a.visible = !!l;
      if (!l) return;
      const dir = new THREE.Vector3(...l.direction);
      const len = 0.18 * diag * (big > 0 && Number.isFinite(l.magnitude) ? 0.5 + 0.5 * (l.magnitude / big) : 1);
      // The tip touches the region's centroid: the load acts on the part there.
      a.position.set(...l.centroid).addScaledVector(dir, -len);
      a.setDirection(dir);
      a.setLength(len, 0.3 * len, 0.15 * len);
    });
  }

  refit() {
    if (!this.surface.surfaceVertexCount) return;
    this.fitView(this.position.array, this.surface.surfaceVertexCount);
    this.needsRender = true;
  }

  fitView(pos, nv) {
    const box = new THREE.Box3();
    const v = new THREE.Vector3();
    for (let i = 0; i < nv; ++i) box.expandByPoint(v.fromArray(pos, 3 * i));
    const c = box.getCenter(new THREE.Vector3());
    this.diagonal = box.getSize(new THREE.Vector3()).length() || 1;
    this.controls.target.copy(c);
    this.camera.position.copy(c).add(new THREE.Vector3(-0.55, 0.5, 1.0).normalize().multiplyScalar(1.7 * this.diagonal));
    this.camera.near = this.diagonal / 100;
    this.camera.far = this.diagonal * 100;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.viewFitted = true;
    this.updateArrows();
  }

  // ---- panels ----------------------------------------------------------------------------------

  renderReadouts() {
    const r = { ...this.readout, ...(this.props ?? {}) };
    // Round-off of exact zeros (products of inertia of a symmetric part: 1e-9 next to 1e7)
    // shows as 0 rather than as noise.
    const Imax = Math.max(...(r.inertia ?? [0]).map(Math.abs));
    const I = (r.inertia ?? []).map((v) => (Math.abs(v) < 1e-9 * Imax ? 0 : v));
    const rows = [
      ['mass', fmt(r.mass)],
      ['volume', fmt(r.volume)],
      ['surface area', fmt(r.area)],
      [`drag proxy: frontal area ${this.directionSelect.selectedOptions[0].text}`, fmt(r.frontalArea)],
      ['Ixx, Iyy, Izz', `${fmt(I[0], 3)}, ${fmt(I[4], 3)}, ${fmt(I[8], 3)}`],
      ['Ixy, Ixz, Iyz', `${fmt(I[1], 3)}, ${fmt(I[2], 3)}, ${fmt(I[5], 3)}`],
      ['centroid', (r.centroid ?? []).map((c) => fmt(c)).join(' ')],
      [`max ${this.stressField || 'stress'}`, `${fmt(r.maxStress)}${this.stressUnit()}`],
      ['error estimate', r.errorEstimate >= 0 ? `${fmt(100 * r.errorEstimate, 3)} % of bbox diagonal` : 'not measured'],
      ['element', String(r.element)],
      ['mesh', `${r.vertices} vertices, ${r.tets} tets, ${r.triangles} triangles`],
    ];
    const t = document.getElementById('readouts');
    if (t.rows.length !== rows.length) {
      t.innerHTML = rows.map(() => '<tr><td></td><td></td></tr>').join('');
    }
    rows.forEach(([k, v], i) => {
      t.rows[i].cells[0].textContent = k;
      t.rows[i].cells[1].textContent = v;
    });
  }

  stressUnit() {
    const u = this.fields.find((f) => f.name === this.stressField)?.unit;
    return u ? ` ${u}` : '';
  }

  renderLegend() {
    const canvas = document.getElementById('legend-bar');
    const ticks = document.getElementById('legend-ticks');
    const ctx = canvas.getContext('2d');
    if (!this.legendDrawn) {
      for (let y = 0; y < canvas.height; ++y) {
        ctx.fillStyle = cssColor(1 - y / (canvas.height - 1));
        ctx.fillRect(0, y, canvas.width, 1);
      }
      this.legendDrawn = true;
    }
    const range = this.colorRange;
    const key = range ? `${range[0]}:${range[1]}:${this.displayField}` : '';
    if (key === this.legendKey) return;
    this.legendKey = key;
    const shown = this.fields.find((f) => f.name === this.displayField);
    document.getElementById('legend-title').textContent = shown
      ? `${shown.components > 1 ? `|${shown.name}|` : shown.name}${shown.unit ? ` in ${shown.unit}` : ' (no unit in the asset)'}`
      : '';
    canvas.style.visibility = range ? 'visible' : 'hidden';
    if (!range) {
      ticks.innerHTML = '';
      return;
    }
    const n = 5;
    ticks.innerHTML = '';
    for (let k = 0; k < n; ++k) {
      const u = k / (n - 1);
      const span = document.createElement('span');
      span.style.top = `${(1 - u) * 100}%`;
      span.textContent = fmt(range[0] + u * (range[1] - range[0]));
      ticks.appendChild(span);
    }
  }

  /** Red hatched runs on each slider track where, the other parameters fixed, the asset is
   *  infeasible (locate() says so). Recomputed only when the other parameters moved. */
  updateMarks() {
    this.sliders.forEach((sl, i) => {
      const key = Array.from(this.x).map((v, j) => (j === i ? '' : v)).join(',');
      if (key === this.markKeys[i]) return;
      this.markKeys[i] = key;
      const p = this.params[i];
      sl.runs = infeasibleRuns(this.asset, this.x, i, p.lower, p.upper);
      const w = p.upper - p.lower || 1;
      sl.marks.innerHTML = sl.runs
        .map(([a, b]) => `<div class="mark" style="left:${(100 * (a - p.lower)) / w}%;width:${(100 * (b - a)) / w}%"></div>`)
        .join('');
      sl.input.title = sl.runs.length
        ? `infeasible for ${sl.runs.map(([a, b]) => `${fmt(a)}–${fmt(b)}`).join(', ')}`
        : '';
    });
  }

  loop() {
    const frame = () => {
      // Scheduled first, so that an exception below cannot stop the page.
      requestAnimationFrame(frame);
      if (this.pending) this.update();
      const tm = performance.now();
      this.updateMarks();
      this.stats.marksMs = performance.now() - tm;
      if (this.needsRender) {
        const tr = performance.now();
        this.controls.update();
        this.renderer.render(this.scene, this.camera); // includes the buffer uploads
        this.stats.renderMs = performance.now() - tr;
        this.needsRender = false;
        this.frames = (this.frames ?? 0) + 1;
      }
      const now = performance.now();
      while (this.rateWindow.length && this.rateWindow[0] < now - 1000) this.rateWindow.shift();
      if (now - (this.lastStatus ?? 0) > 250) {
        this.lastStatus = now;
        document.getElementById('status').textContent =
          `runtime ${this.lib.version} (WebAssembly) · last update ${fmt(this.stats.lastUpdateMs, 3)} ms ` +
          `(eval ${fmt(this.stats.evalMs, 3)} ms, surface ${fmt(this.stats.surfaceMs, 3)} ms) · properties ${fmt(this.stats.propsMs, 3)} ms` +
          `${this.worker ? ' (worker)' : ''} · ` +
          `${this.rateWindow.length} updates/s` +
          (this.propsError ? ` · properties failed: ${this.propsError}` : '');
      }
    };
    requestAnimationFrame(frame);
  }

  // ---- test hook -------------------------------------------------------------------------------

  installHook() {
    Object.assign(hook, {
      parameters: this.params,
      fields: this.fields.map((f) => ({ ...f })),
      regions: this.regions.map((r) => ({ name: r.name, kind: r.kind, faceTags: Array.from(r.faceTags) })),
      // The setters update at once and resolve, with the state, when the mass properties shown
      // answer the new shape (they come from the worker a little later).
      /** Sets parameter i (as a slider move would). */
      setParam: (i, v) => {
        this.x[i] = v;
        this.syncSliders();
        this.update();
        this.updateMarks();
        return hook.settled();
      },
      setX: (x) => {
        this.x.set(x);
        this.syncSliders();
        this.update();
        this.updateMarks();
        return hook.settled();
      },
      setField: (name) => {
        const sel = document.getElementById('field-select');
        sel.value = name;
        sel.dispatchEvent(new Event('change'));
        this.update();
        return hook.settled();
      },
      setDensity: (d) => {
        this.densityInput.value = String(d);
        this.densityInput.dispatchEvent(new Event('input'));
        return hook.settled();
      },
      settled: () =>
        new Promise((resolve) => {
          const check = () => (this.propertiesCurrent() || this.propsError ? resolve(hook.state()) : setTimeout(check, 2));
          check();
        }),
      state: () => ({
        x: Array.from(this.x),
        evaluatedX: this.evaluatedX && Array.from(this.evaluatedX),
        infeasible: this.infeasible,
        message: this.message,
        displayField: this.displayField,
        stressField: this.stressField,
        colorRange: this.colorRange,
        readout: JSON.parse(JSON.stringify({ ...this.readout, ...(this.props ?? {}) })),
        propertiesFor: this.propsFor,
        propertiesCurrent: this.propertiesCurrent(),
        propertiesError: this.propsError,
        worker: !!this.worker,
        stats: { ...this.stats },
        marks: this.sliders.map((s) => s.runs),
        arrows: this.arrows.map((a, k) => ({
          region: this.forceRegions[k].name,
          visible: a.visible,
          position: a.position.toArray(),
          direction: new THREE.Vector3(0, 1, 0).applyQuaternion(a.quaternion).toArray(),
          length: a.cone.position.y,
          source: this.loads[k]?.source ?? null,
          traction: this.loads[k]?.traction ?? null,
          magnitude: this.loads[k]?.magnitude ?? null,
          label: this.loadLabels[k].span.textContent,
        })),
        legendTitle: document.getElementById('legend-title').textContent,
        legendTicks: Array.from(document.querySelectorAll('#legend-ticks span')).map((s) => s.textContent),
        overlayTriangles: this.overlay ? this.overlay.geometry.drawRange.count / 3 : 0,
      }),
      /** What is drawn: the surface vertices' ids in the full mesh and their positions. */
      surface: () => {
        const n = this.surface.surfaceVertexCount;
        return {
          vertexIds: Array.from(this.surface.surfaceVertices),
          positions: Array.from(this.position.array.subarray(0, 3 * n)),
          colors: Array.from(this.color.array.subarray(0, 3 * n)),
          triangles: this.surface.triangleCount,
        };
      },
      /**
       * A programmatic drag: every animation frame moves slider i a step (back and forth across
       * its range, avoiding nothing: infeasible stretches cost no eval) through the same input
       * event a mouse drag fires; resolves with frames and updates per second.
       */
      // mode 'render': the slider stays, the unchanged mesh is drawn every frame (what drawing
      // alone costs); 'idle': nothing changes and nothing is drawn (the frame clock's own rate).
      benchDrag: (i, seconds = 3, mode = 'drag') =>
        new Promise((resolve) => {
          const p = this.params[i];
          const input = this.sliders[i].input;
          const u0 = this.stats.updates, p0 = this.stats.propsUpdates ?? 0;
          let frames = 0, t0 = null, worst = 0, last = null, updateMs = 0;
          const sums = { evalMs: 0, gatherMs: 0, normalsMs: 0, coloursMs: 0, restMs: 0, renderMs: 0 };
          let renders = 0, r0 = this.frames ?? 0;
          const step = (now) => {
            if (t0 === null) t0 = now;
            if (last !== null) worst = Math.max(worst, now - last);
            last = now;
            const t = (now - t0) / 1000;
            if (t >= seconds) {
              const u = this.stats.updates - u0;
              const pu = (this.stats.propsUpdates ?? 0) - p0;
              const mean = (k, n) => (n ? sums[k] / n : 0);
              resolve({
                mode, subset: this.useSubset,
                seconds: t, frames, updates: u, fps: frames / t, updatesPerSecond: u / t, worstFrameMs: worst,
                meanUpdateMs: u ? updateMs / u : 0, propertiesPerSecond: pu / t, propertiesMs: this.stats.propsMs,
                propertiesInWorker: !!this.worker, evalMs: this.stats.evalMs, surfaceMs: this.stats.surfaceMs,
                marksMs: this.stats.marksMs,
                // Per-update means of the stages of update() and per drawn frame of render().
                stages: {
                  evalMs: mean('evalMs', u), gatherMs: mean('gatherMs', u), normalsMs: mean('normalsMs', u),
                  coloursMs: mean('coloursMs', u), restMs: mean('restMs', u), renderMs: mean('renderMs', renders),
                },
                renderedFrames: (this.frames ?? 0) - r0,
                // Triangles drawn at the end of the drag (fewer than the surface's: the coarse one).
                drawnTriangles: Math.min(this.mesh.geometry.drawRange.count, this.mesh.geometry.index.count) / 3,
                surfaceTriangles: this.surface.triangleCount,
              });
              return;
            }
            // The previous frame's render (it ran after this callback, in the page's loop).
            if ((this.frames ?? 0) > r0 + renders) {
              renders = (this.frames ?? 0) - r0;
              sums.renderMs += this.stats.renderMs ?? 0;
            }
            frames += 1;
            if (mode !== 'drag') {
              if (mode === 'render') this.needsRender = true;
              requestAnimationFrame(step);
              return;
            }
            const phase = (t / 2) % 1; // a full sweep up and down every 2 s
            const u = phase < 0.5 ? 2 * phase : 2 - 2 * phase;
            input.value = String(p.lower + u * (p.upper - p.lower));
            input.dispatchEvent(new Event('input', { bubbles: true }));
            const before = this.stats.updates;
            const s0 = performance.now();
            if (this.pending) this.update();
            if (this.stats.updates > before) {
              updateMs += performance.now() - s0;
              for (const k of ['evalMs', 'gatherMs', 'normalsMs', 'coloursMs', 'restMs']) sums[k] += this.stats[k] ?? 0;
            }
            requestAnimationFrame(step);
          };
          requestAnimationFrame(step);
        }),
      /** The Optimize panel: availability, the last result or error, whether it runs. */
      optimizer: () => this.optimizer.state(),
      frames: () => this.frames ?? 0,
      antialias: this.renderer.getContext().getContextAttributes().antialias,
      ready: true,
    });
  }
}

/** The properties worker, or null (the page then computes them itself) if it cannot start. */
async function startWorker(wasmUrl, bytes, explorer) {
  let worker;
  try {
    worker = new Worker(new URL('./properties-worker.js', import.meta.url), { type: 'module' });
  } catch (e) {
    console.warn(`no properties worker (${e.message}): computing them on the main thread`);
    return null;
  }
  const ready = await new Promise((resolve) => {
    worker.onmessage = (e) => resolve(e.data);
    worker.onerror = (e) => resolve({ type: 'error', message: e.message });
    worker.postMessage({ type: 'init', wasmUrl, bytes }, [bytes]);
  });
  if (ready.type !== 'ready') {
    console.warn(`the properties worker failed (${ready.message}): computing them on the main thread`);
    worker.terminate();
    return null;
  }
  worker.onmessage = (e) => explorer.onWorkerMessage(e.data);
  return worker;
}

async function main() {
  const params = new URLSearchParams(location.search);
  const base = document.baseURI;
  const assetUrl = new URL(params.get('asset') ?? 'api/asset.cadi', base).href;
  const wasmUrl = new URL(`${params.get('wasm') ?? 'wasm'}/cadinterp.mjs`, base).href;
  const [{ load }, bytes, info] = await Promise.all([
    import(/* @vite-ignore */ wasmUrl),
    fetch(assetUrl).then((r) => {
      if (!r.ok) throw new Error(`cannot fetch the asset ${assetUrl}: HTTP ${r.status}`);
      return r.arrayBuffer();
    }),
    fetch(new URL('api/asset.json', base))
      .then((r) => (r.ok ? r.json() : {}))
      .catch(() => ({})),
  ]);
  const lib = await load();
  const asset = lib.open(bytes); // copies the bytes into the WebAssembly heap
  if (!info.name) info.name = assetUrl.split('/').pop();
  const explorer = new Explorer(lib, asset, info);
  if (params.get('worker') !== '0') explorer.worker = await startWorker(wasmUrl, bytes, explorer);
  explorer.start();
}

main().catch((e) => {
  console.error(e);
  hook.error = `${e.name}: ${e.message}${e.statusName ? ` (${e.statusName})` : ''}`;
  const el = document.createElement('div');
  el.id = 'fatal';
  el.textContent = `The explorer could not start.\n\n${hook.error}`;
  document.getElementById('view').appendChild(el);
  document.getElementById('asset-name').textContent = 'failed to load';
});
