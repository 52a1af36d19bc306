// Mass properties off the main thread. cadinterp_eval_properties integrates over every tet of
// the mesh at x (490k tets on the 90k-vertex bracket: ~20 ms in WebAssembly), which would halve
// the frame rate of a slider drag if it ran between frames. This worker holds its own instance
// of the runtime and its own copy of the asset, and answers the latest request; the page keeps
// drawing the mesh every frame and shows the properties as they arrive (one computation behind
// at most).
//
// It also answers what needs every tet's (or vertex's) field value, which the page no longer
// evaluates per frame (it blends the drawn surface only, cadinterp_eval_subset): the value range
// of the displayed field (the colour map's and the legend's range) and the max of the stress
// field (the readout), exactly as the native runtime would compute them at the same x.
//
// Messages in:  { type: 'init', wasmUrl, bytes }
//               { type: 'properties', id, x, density, direction, ranges: [field names] }
// Messages out: { type: 'ready', version } | { type: 'error', message }
//               { type: 'properties', id, x, properties, ranges: { name: [min, max] } }
//               | { type: 'properties', id, x, error }
import { propertiesAndRanges } from './surface.js';

let asset = null;

self.onmessage = async (event) => {
  const m = event.data;
  if (m.type === 'init') {
    try {
      const { load } = await import(/* @vite-ignore */ m.wasmUrl);
      const lib = await load();
      asset = lib.open(m.bytes);
      self.postMessage({ type: 'ready', version: lib.version });
    } catch (e) {
      self.postMessage({ type: 'error', message: `${e.message}${e.statusName ? ` (${e.statusName})` : ''}` });
    }
    return;
  }
  if (m.type === 'properties') {
    try {
      const { properties, ranges } = propertiesAndRanges(asset, m);
      self.postMessage({ type: 'properties', id: m.id, x: m.x, properties, ranges });
    } catch (e) {
      self.postMessage({ type: 'properties', id: m.id, x: m.x, error: `${e.message}${e.statusName ? ` (${e.statusName})` : ''}` });
    }
  }
};
