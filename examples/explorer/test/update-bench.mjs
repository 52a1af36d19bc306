// The page's per-slider-move work without a browser (no rendering, no compositor): the same
// modules and calls as src/main.js update(), timed in Node on the WebAssembly runtime.
//   node test/update-bench.mjs ASSET [WASM_DIR=build/wasm] [STEPS=200]
// Prints the median and 90th percentile of each stage over a sweep of every parameter.
import { readFileSync } from 'node:fs';
import { resolve } from 'node:path';
import { pathToFileURL } from 'node:url';
import { Surface, fieldMax, fieldRange } from '../src/surface.js';
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
const t = { locate: [], eval: [], surface: [], properties: [], total: [] };
const surface = new Surface();
let pos, nrm, col, scal;
const params = asset.parameters;
let meta = null;
for (let i = 0; i < params.length; ++i) {
  const x = params.map((p) => 0.5 * (p.lower + p.upper));
  for (let s = 0; s < steps; ++s) {
    x[i] = params[i].lower + ((s + 0.5) / steps) * (params[i].upper - params[i].lower);
    const t0 = performance.now();
    if (!asset.locate(x).feasible) continue;
    const t1 = performance.now();
    const m = asset.eval(x, stress ? [stress.name] : []);
    const t2 = performance.now();
    if (surface.sync(m) || !pos) {
      const n = surface.surfaceVertexCount;
      pos = new Float32Array(3 * n); nrm = new Float32Array(3 * n); col = new Float32Array(3 * n); scal = new Float32Array(n);
    }
    surface.gatherPositions(m.positions, pos);
    surface.computeNormals(pos, nrm);
    if (stress) {
      const v = m.fields[stress.name];
      const range = fieldRange(v, stress.components);
      surface.vertexValues(v, stress.location, stress.components, scal);
      colorize(scal, surface.surfaceVertexCount, range[0], range[1], col);
      fieldMax(v, stress.components);
    }
    meta ??= { vertices: m.vertexCount, tets: m.tetCount, triangles: m.triangleCount, surfaceVertices: surface.surfaceVertexCount };
    const t3 = performance.now();
    asset.properties(x, { density: 1, direction: [1, 0, 0] });
    const t4 = performance.now();
    t.locate.push(t1 - t0); t.eval.push(t2 - t1); t.surface.push(t3 - t2); t.properties.push(t4 - t3); t.total.push(t3 - t0);
  }
}
const q = (a, f) => [...a].sort((u, v) => u - v)[Math.min(a.length - 1, Math.floor(f * a.length))];
const out = { asset: assetPath, runtime: lib.version, field: stress?.name, ...meta, samples: t.eval.length };
for (const [k, a] of Object.entries(t)) out[k] = { medianMs: +q(a, 0.5).toFixed(3), p90Ms: +q(a, 0.9).toFixed(3) };
out.mainThreadUpdatesPerSecond = +(1000 / q(t.total, 0.5)).toFixed(1);
console.log(JSON.stringify(out, null, 2));
