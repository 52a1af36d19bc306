// Colour map for scalar fields: viridis (perceptually uniform, readable in grey and by most
// colour-blind viewers), as 9 stops interpolated into a 256-entry table once.
const STOPS = [
  [0.267, 0.005, 0.329],
  [0.283, 0.141, 0.458],
  [0.254, 0.265, 0.53],
  [0.207, 0.372, 0.553],
  [0.164, 0.471, 0.558],
  [0.128, 0.567, 0.551],
  [0.135, 0.659, 0.518],
  [0.267, 0.749, 0.441],
  [0.478, 0.821, 0.318],
  [0.741, 0.873, 0.15],
  [0.993, 0.906, 0.144],
];

export const LUT_SIZE = 256;
export const LUT = (() => {
  const t = new Float32Array(3 * LUT_SIZE);
  for (let i = 0; i < LUT_SIZE; ++i) {
    const u = (i / (LUT_SIZE - 1)) * (STOPS.length - 1);
    const k = Math.min(Math.floor(u), STOPS.length - 2);
    const f = u - k;
    for (let c = 0; c < 3; ++c) t[3 * i + c] = STOPS[k][c] * (1 - f) + STOPS[k + 1][c] * f;
  }
  return t;
})();

/** Writes RGB for `n` values into `out` (3 per value), mapping [lo, hi] onto the table. */
export function colorize(values, n, lo, hi, out) {
  const scale = hi > lo ? (LUT_SIZE - 1) / (hi - lo) : 0;
  for (let i = 0; i < n; ++i) {
    let k = Math.round((values[i] - lo) * scale);
    k = k < 0 ? 0 : k > LUT_SIZE - 1 ? LUT_SIZE - 1 : k;
    out[3 * i] = LUT[3 * k];
    out[3 * i + 1] = LUT[3 * k + 1];
    out[3 * i + 2] = LUT[3 * k + 2];
  }
}

/** CSS colour of the table at u in [0, 1]. */
export function cssColor(u) {
  const k = Math.max(0, Math.min(LUT_SIZE - 1, Math.round(u * (LUT_SIZE - 1))));
  const c = (j) => Math.round(255 * LUT[3 * k + j]);
  return `rgb(${c(0)}, ${c(1)}, ${c(2)})`;
}
