// WebAssembly half of scripts/bench-wasm.sh: the measurements of bench_native.cpp through the
// JavaScript API. Usage: node bench.mjs WASM_DIR ASSET [N]; prints one JSON line.
import { readFileSync } from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const [wasmDir, assetPath, nArg] = process.argv.slice(2);
const n = Math.max(1, Number(nArg ?? 200));
const { load } = await import(pathToFileURL(path.join(path.resolve(wasmDir), 'cadinterp.mjs')).href);
const lib = await load();
const bytes = readFileSync(assetPath);

// The points of bench_native.cpp: eight in one element (see there).
const points = [[0.3, 0.6, 0.2], [0.25, 0.65, 0.15], [0.35, 0.55, 0.25], [0.2, 0.7, 0.3],
  [0.4, 0.6, 0.1], [0.3, 0.7, 0.25], [0.22, 0.58, 0.18], [0.38, 0.66, 0.28]];

function medianMs(count, call) {
  call(0);
  const t = [];
  for (let i = 0; i < count; ++i) {
    const t0 = process.hrtime.bigint();
    call(i);
    t.push(Number(process.hrtime.bigint() - t0) / 1e6);
  }
  t.sort((a, b) => a - b);
  return t[Math.floor(count / 2)];
}

// open (the bytes are copied into the heap) + first eval (decodes the element).
const first = [];
for (let r = 0; r < 5; ++r) {
  const t0 = process.hrtime.bigint();
  const a = lib.open(bytes);
  a.eval(points[0], []);
  first.push(Number(process.hrtime.bigint() - t0) / 1e6);
  a.close();
}
first.sort((a, b) => a - b);

const a = lib.open(bytes);
let m;
for (const x of points) {
  const e = m?.element;
  m = a.eval(x, []);
  if (e !== undefined && m.element !== e) throw new Error('the points are not in one element');
}
const nv = m.vertexCount;
const evalMs = medianMs(n, (i) => a.eval(points[i % 8], []));
const evalFieldMs = medianMs(n, (i) => a.eval(points[i % 8], ['temperature']));
const gradMs = medianMs(n, (i) => a.grad(points[i % 8], []));
const adj = new Float32Array(3 * nv).fill(1);
const vjpMs = medianMs(n, (i) => a.vjp(points[i % 8], adj));
const propsMs = medianMs(n, (i) => a.properties(points[i % 8], { direction: [0, 0, 1] }));
console.log(JSON.stringify({
  vertices: nv, eval_ms: evalMs, eval_field_ms: evalFieldMs, grad_ms: gradMs, vjp_ms: vjpMs,
  properties_ms: propsMs, first_eval_ms: first[2], heap_mb: lib.memoryStats().heapBytes / 2 ** 20,
}));
a.close();
