// Shared by the Node tests: loads the built module (CADINTERP_WASM_DIR, default build/wasm of
// this checkout) and reads the conformance cases (conformance/runner.cpp documents the format).
import { readFileSync, readdirSync, existsSync } from 'node:fs';
import { fileURLToPath, pathToFileURL } from 'node:url';
import path from 'node:path';

const here = path.dirname(fileURLToPath(import.meta.url));
export const repoRoot = path.resolve(here, '../../..');
export const wasmDir = path.resolve(process.env.CADINTERP_WASM_DIR ?? path.join(repoRoot, 'build/wasm'));
export const casesDir = path.join(repoRoot, 'conformance/cases');

let libPromise = null;
/** The wrapper module and one loaded library, shared by the tests of a file. */
export async function library() {
  const entry = path.join(wasmDir, 'cadinterp.mjs');
  if (!existsSync(entry)) throw new Error(`${entry} missing: run scripts/build-wasm.sh`);
  libPromise ??= import(pathToFileURL(entry).href).then(async (api) => ({ api, lib: await api.load() }));
  return libPromise;
}

export function caseBytes(group, name) {
  return readFileSync(path.join(casesDir, group, name, 'asset.cadi'));
}

export function caseNames(group) {
  return readdirSync(path.join(casesDir, group)).sort();
}

/** C99 hexadecimal float ("-0x1.8p+3") or decimal text to a double, exactly. */
export function parseNumber(s) {
  const m = /^([+-]?)0x([0-9a-f]+)(?:\.([0-9a-f]*))?p([+-]?\d+)$/i.exec(s);
  if (!m) {
    const v = Number(s);
    if (Number.isNaN(v) && !/^[+-]?nan$/i.test(s)) throw new Error(`not a number: ${s}`);
    return v;
  }
  const frac = m[3] ?? '';
  const mant = BigInt(`0x${m[2]}${frac}`); // <= 53 significant bits in the generator's output
  let e = Number(m[4]) - 4 * frac.length;
  let v = Number(mant);
  // Scale in steps so that 2**e never underflows or overflows on its own.
  while (e > 1000) { v *= 2 ** 1000; e -= 1000; }
  while (e < -1000) { v *= 2 ** -1000; e += 1000; }
  v *= 2 ** e;
  return m[1] === '-' ? -v : v;
}

/**
 * expected.txt as a list of steps:
 * { open: status } | { tolerance } | { gradTolerance } | units: { [field index]: unit ('' for none) } |
 * { point: [...], status, element?, positions?, dpositions: [[...] x K], field0?, dfield0: [...] }
 */
export function parseExpected(group, name) {
  const text = readFileSync(path.join(casesDir, group, name, 'expected.txt'), 'utf8');
  const out = { open: null, tolerance: 1e-5, gradTolerance: 1e-4, points: [], units: {} };
  let cur = null;
  for (const line of text.split('\n')) {
    const tok = line.trim().split(/\s+/);
    if (!tok[0] || tok[0].startsWith('#')) continue;
    const nums = () => tok.slice(1).map(parseNumber);
    switch (tok[0]) {
      case 'open': out.open = tok[1]; break;
      case 'open_message': out.openMessage = tok.slice(1).join(' '); break;
      case 'tolerance': out.tolerance = Number(tok[1]); break;
      case 'grad_tolerance': out.gradTolerance = Number(tok[1]); break;
      case 'unit': out.units[Number(tok[1])] = tok[2] === '-' ? '' : tok[2]; break;
      case 'point': cur = { x: nums(), dpositions: [], dfield0: [] }; out.points.push(cur); break;
      case 'status': cur.status = tok[1]; break;
      case 'element': cur.element = Number(tok[1]); break;
      case 'positions': cur.positions = nums(); break;
      case 'dpositions': cur.dpositions.push(nums()); break;
      case 'field0': cur.field0 = nums(); break;
      case 'dfield0': cur.dfield0.push(nums()); break;
      // Format 1.3 outputs: checked by the native runner (cadinterp_eval_outputs); parsed here.
      case 'output': (out.outputs ??= []).push({ index: Number(tok[1]), name: tok[2], unit: tok[3] }); break;
      case 'outputs': cur.outputs = nums(); break;
      case 'doutputs': (cur.doutputs ??= []).push(nums()); break;
      default: throw new Error(`${group}/${name}: unknown line ${line}`);
    }
  }
  return out;
}

/** Asserts |got - want| <= tol (1 + |want|) element-wise, as the native runner does. */
export function assertClose(got, want, tol, what) {
  if (got.length < want.length) throw new Error(`${what}: ${got.length} values, expected ${want.length}`);
  for (let i = 0; i < want.length; ++i) {
    if (!(Math.abs(got[i] - want[i]) <= tol * (1 + Math.abs(want[i])))) {
      throw new Error(`${what}[${i}]: got ${got[i]}, expected ${want[i]} (tolerance ${tol})`);
    }
  }
}

/** A deterministic generator of doubles in [0, 1) (tests must not depend on Math.random). */
export function rng(seed) {
  let s = BigInt(seed) || 1n;
  return () => {
    s ^= s << 13n; s &= 0xffffffffffffffffn;
    s ^= s >> 7n;
    s ^= s << 17n; s &= 0xffffffffffffffffn;
    return Number(s >> 11n) / 2 ** 53;
  };
}
