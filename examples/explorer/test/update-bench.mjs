// The page's per-slider-move work without a browser (no rendering, no compositor): the same
// modules and calls as src/main.js update(), timed in Node on the WebAssembly runtime.
//   node test/update-bench.mjs ASSET [WASM_DIR=build/wasm] [STEPS=200]
// Prints the median and 90th percentile of each stage over a sweep of every parameter, for the
// whole-mesh eval and the surface-only eval (cadinterp_eval_subset), alternately twice each.
import { readFileSync } from 'node:fs';
import { resolve } from 'node:path';
import { pathToFileURL } from 'node:url';
import { Surface, fieldRange, propertiesAndRanges } from '../src/surface.js';
import { colorize } from '../src/colormap.js';

const [assetPath, wasmDir = resolve(import.meta.dirname, '../../../build/wasm'), stepsArg = '200'] = process.argv.slice(2);
if (!assetPath) {
  console.error('usage: node test/update-bench.mjs ASSET [WASM_DIR] [STEPS]');
  process.exit(2);
}
const { load } = await import(pathToFileURL(resolve(wasmDir, 'cadinterp.mjs')).href);
const lib = await load();
const asset = lib.open(readFileSync(assetPath));
const stress = asset.fields.find((f) => /stress|mises/i.test(f.name)) ?? asset.fields[0];
const steps = Number(stepsArg);
const params = asset.parameters;
const q = (a, f) => [...a].sort((u, v) => u - v)[Math.min(a.length - 1, Math.floor(f * a.length))];

// One sweep of every parameter, timing the stages of the page's update() (src/main.js):
// 'full' evaluates the whole mesh and gathers the surface from it (the page with ?subset=0),
// 'subset' evaluates the surface rows only (cadinterp_eval_subset, the page's default) and
// leaves the field's whole range and max stress to the worker (timed here as 'worker').
function sweep(mode) {
  const t = { locate: [], eval: [], normals: [], colours: [], total: [], worker: [] };
  const surface = new Surface();
  let pos, nrm, col, scal, meta = null;
  for (let i = 0; i < params.length; ++i) {
    const x = params.map((p) => 0.5 * (p.lower + p.upper));
    for (let s = 0; s < steps; ++s) {
      x[i] = params[i].lower + ((s + 0.5) / steps) * (params[i].upper - params[i].lower);
      const t0 = performance.now();
      const loc = asset.locate(x);
      if (!loc.feasible) continue;
      const t1 = performance.now();
      let m;
      if (mode === 'subset') {
        if (surface.element !== loc.element || !surface.version) surface.sync(asset.evalSubset(x, {}, []));
        m = asset.evalSubset(x, surface.subsetIds(), stress ? [stress.name] : []);
      } else {
        m = asset.eval(x, stress ? [stress.name] : []);
        surface.sync(m);
      }
      const n = surface.surfaceVertexCount;
      if (!pos || pos.length !== 3 * n) {
        pos = new Float32Array(3 * n); nrm = new Float32Array(3 * n); col = new Float32Array(3 * n); scal = new Float32Array(n);
      }
      if (mode === 'subset') pos.set(m.positions);
      else surface.gatherPositions(m.positions, pos);
      const t2 = performance.now();
      surface.computeNormals(pos, nrm);
      const t3 = performance.now();
      if (stress) {
        const v = m.fields[stress.name];
        if (mode === 'subset') {
          surface.surfaceValues(v, stress.location, stress.components, scal);
          colorize(scal, n, 0, 1, col); // the range comes from the worker
        } else {
          const range = fieldRange(v, stress.components);
          surface.vertexValues(v, stress.location, stress.components, scal);
          colorize(scal, n, range[0], range[1], col);
        }
      }
      meta ??= { vertices: m.vertexCount, tets: m.tetCount, triangles: m.triangleCount, surfaceVertices: n, surfaceTets: surface.subsetIds().tets.length };
      const t4 = performance.now();
      // Off the main thread in the page: properties, plus (subset) the field's whole range.
      if (mode === 'subset') propertiesAndRanges(asset, { x, density: 1, direction: [1, 0, 0], ranges: stress ? [stress.name] : [] });
      else asset.properties(x, { density: 1, direction: [1, 0, 0] });
      const t5 = performance.now();
      t.locate.push(t1 - t0); t.eval.push(t2 - t1); t.normals.push(t3 - t2); t.colours.push(t4 - t3);
      t.total.push(t4 - t0); t.worker.push(t5 - t4);
    }
  }
  const out = { mode, ...meta, samples: t.eval.length };
  for (const [k, a] of Object.entries(t)) out[k] = { medianMs: +q(a, 0.5).toFixed(3), p90Ms: +q(a, 0.9).toFixed(3) };
  out.mainThreadUpdatesPerSecond = +(1000 / q(t.total, 0.5)).toFixed(1);
  return out;
}

// Alternated, so that the machine's load (shared) falls on both alike.
const runs = [];
for (const mode of ['full', 'subset', 'full', 'subset']) runs.push(sweep(mode));
console.log(JSON.stringify({ asset: assetPath, runtime: lib.version, field: stress?.name, runs }, null, 2));
