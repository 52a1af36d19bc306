// Frame rate while dragging each slider (not a test: a measurement to report).
//   CADINTERP_CLI=... [EXPLORER_QUERY='?worker=0'] node test/fps.mjs ASSET [SECONDS] [MODES]
// Serves ASSET with `cadinterp explore`, opens it in headless Chromium and, for each parameter,
// moves its slider every animation frame for SECONDS through the same input event a mouse drag
// fires (window.__explorer.benchDrag): frames per second, evaluations per second and the time
// of one update (eval + surface gather + normals + colours + properties), as JSON on stdout.
// MODES (comma-separated, default "drag"): also "render" (the unchanged mesh drawn every frame:
// what drawing alone costs, the ceiling of the drag's frame rate) and "idle" (nothing drawn:
// the frame clock's own rate); those two run once, not per slider.
// EXPLORER_QUERY '?subset=0' evaluates the whole mesh per move, as the page did before.
import { launchBrowser, openPage, startServer } from './harness.mjs';

const [asset, seconds = '3', modesArg = 'drag'] = process.argv.slice(2);
const modes = modesArg.split(',');
if (!asset) {
  console.error('usage: node test/fps.mjs ASSET [SECONDS]');
  process.exit(2);
}
const server = await startServer(asset);
const browser = await launchBrowser();
try {
  // EXPLORER_QUERY, e.g. '?worker=0' (properties on the main thread) or '?aa=1' (multisampling).
  const { page, problems } = await openPage(browser.context, server.url + (process.env.EXPLORER_QUERY ?? ''));
  const info = await page.evaluate(() => ({
    parameters: window.__explorer.parameters.map((p) => p.name),
    readout: window.__explorer.state().readout,
    surface: window.__explorer.surface().vertexIds.length,
  }));
  const gl = await page.evaluate(() => {
    const c = document.createElement('canvas').getContext('webgl2');
    const ext = c?.getExtension('WEBGL_debug_renderer_info');
    return ext ? c.getParameter(ext.UNMASKED_RENDERER_WEBGL) : 'unknown';
  });
  const x0 = await page.evaluate(() => window.__explorer.state().evaluatedX);
  const results = [];
  for (const mode of modes) {
    for (let i = 0; i < (mode === 'drag' ? info.parameters.length : 1); ++i) {
      // Each slider from the same start, so one sweep's end point does not decide the next.
      await page.evaluate((x) => window.__explorer.setX(x), x0);
      const r = await page.evaluate(([k, s, md]) => window.__explorer.benchDrag(k, s, md), [i, Number(seconds), mode]);
      results.push({ parameter: mode === 'drag' ? info.parameters[i] : null, ...r });
    }
  }
  const out = {
    asset,
    renderer: gl,
    vertices: info.readout.vertices,
    tets: info.readout.tets,
    triangles: info.readout.triangles,
    surfaceVertices: info.surface,
    query: process.env.EXPLORER_QUERY ?? '',
    viewport: '1280x800 (canvas 920x800)',
    antialias: await page.evaluate(() => window.__explorer.antialias),
    load: (await import('node:os')).loadavg(),
    results,
    problems,
  };
  console.log(JSON.stringify(out, null, 2));
} finally {
  await browser.close();
  await server.stop();
}
