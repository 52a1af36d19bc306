#!/usr/bin/env bash
# End-to-end tests of the web explorer (examples/explorer, `cadinterp explore`) in headless
# Chromium, against the native runtime:
#   scripts/test-explorer.sh [--fps] [--fps-large]
#     --fps        also measure frames per second while dragging each slider (small bracket)
#     --fps-large  the same on a 90k-vertex bracket (cells=32; its build takes ~40 s)
# Each also prints the page's per-move work without a browser (test/update-bench.mjs).
# Environment: BUILD_DIR (default build/release; configured and built here if needed, targets
# cadinterp_cli and cadinterp_explorer_page only), JOBS (default 2), EXPLORER_WASM_DIR (the
# WebAssembly runtime the page and the benchmarks use, default build/wasm).
# Needs node >= 18, Debian's chromium (/usr/bin/chromium), the npm registry once (`npm install`), and
# the WebAssembly runtime in build/wasm (scripts/build-wasm.sh, run here when it is missing).
# Screenshots and measurements land in $BUILD_DIR/explorer-test/.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
fps=0
fps_large=0
for a in "$@"; do
  case $a in
    --fps) fps=1 ;;
    --fps-large) fps=1 fps_large=1 ;;
    *) echo "usage: $0 [--fps] [--fps-large]" >&2; exit 2 ;;
  esac
done
build=${BUILD_DIR:-build/release}
jobs=${JOBS:-2}
explorer=examples/explorer

# npm install when node_modules is missing or older than the lock file: it installs exactly the
# locked versions. The lock records every platform's optional packages (rollup's native builds),
# as npm writes it, so that the install leaves it unchanged and the tree clean.
if [ ! -f $explorer/node_modules/.package-lock.json ] ||
   [ $explorer/package-lock.json -nt $explorer/node_modules/.package-lock.json ]; then
  (cd $explorer && npm install --no-audit --no-fund)
fi
wasm_dir=${EXPLORER_WASM_DIR:-build/wasm}
if [ ! -f "$wasm_dir/cadinterp.mjs" ] || [ ! -f "$wasm_dir/cadinterp_wasm.wasm" ]; then
  if [ -n "${EXPLORER_WASM_DIR:-}" ]; then
    echo "test-explorer: EXPLORER_WASM_DIR=$EXPLORER_WASM_DIR lacks cadinterp.mjs / cadinterp_wasm.wasm" >&2
    exit 1
  elif [ -x scripts/build-wasm.sh ]; then
    scripts/build-wasm.sh
  else
    echo "test-explorer: $wasm_dir/ lacks the WebAssembly runtime and there is no scripts/build-wasm.sh" >&2
    exit 1
  fi
fi
if [ ! -f "$build/build.ninja" ] && [ ! -f "$build/Makefile" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCADINTERP_BUILD_BENCHMARKS=OFF
fi
targets="cadinterp_cli cadinterp_explorer_page"
# The OCCT wrench test (test/loads.test.mjs) needs the OpenCASCADE host, when the build has it.
if grep -q '^build cadinterp_host_occt:' "$build/build.ninja" 2>/dev/null; then
  targets="$targets cadinterp_host_occt"
fi
cmake --build "$build" --target $targets -j "$jobs"

work=$root/$build/explorer-test
mkdir -p "$work"
export CADINTERP_CLI=$root/$build/src/tools/cadinterp
export EXPLORER_WORK_DIR=$work
export EXPLORER_SCREENSHOT_DIR=$work/screenshots
occt_so=$(find "$root/$build/examples/hosts/occt" -maxdepth 1 -name 'libcadinterp_host_occt.so' 2>/dev/null | head -1)
export EXPLORER_OCCT_HOST=${occt_so:-}
[ -n "$EXPLORER_OCCT_HOST" ] || echo "test-explorer: no OCCT host in $build: the wrench load-arrow tests are skipped"
rm -f "$work"/*.cadi  # assets are rebuilt with this cadinterp
node --test --test-reporter=spec $explorer/test/surface.test.mjs $explorer/test/e2e.test.mjs \
  $explorer/test/loads.test.mjs $explorer/test/optimize.test.mjs
echo "screenshots: $EXPLORER_SCREENSHOT_DIR"

if [ "$fps" = 1 ]; then
  # Assets without infeasible parts (every slider move is an evaluation), kept across runs.
  mkdir -p "$work/fps"
  fps_asset() {  # fps_asset NAME CELLS
    local out=$work/fps/$1.cadi
    [ -f "$out" ] || "$CADINTERP_CLI" build --host analytic --model bracket --host-options "cells=$2" \
      --max-samples "$3" --threads 2 -q -o "$out" >/dev/null
    echo "$out"
  }
  small=$(fps_asset bracket_cells4 4 150)
  node $explorer/test/fps.mjs "$small" 3 | tee "$work/fps-small.json"
  node $explorer/test/update-bench.mjs "$small" "$wasm_dir" 100 | tee "$work/update-small.json"
  if [ "$fps_large" = 1 ]; then
    large=$(fps_asset bracket_cells32 32 20)  # 90321 vertices, 491520 tets; ~40 s to build
    # The drag, then the unchanged mesh drawn every frame (what drawing alone costs: the drag's
    # ceiling on software GL), then the same drag as the page did before (the whole mesh
    # evaluated per move, properties requested back to back: ?subset=0&propsms=0).
    node $explorer/test/fps.mjs "$large" 3 drag,render | tee "$work/fps-large.json"
    EXPLORER_QUERY='?subset=0&propsms=0' node $explorer/test/fps.mjs "$large" 3 drag | tee "$work/fps-large-before.json"
    node $explorer/test/update-bench.mjs "$large" "$wasm_dir" 50 | tee "$work/update-large.json"
  fi
fi
