#!/usr/bin/env bash
# Builds the runtime for WebAssembly: build/wasm/cadinterp_wasm.{mjs,wasm} (Emscripten ES module)
# and build/wasm/cadinterp.mjs (the JavaScript API, bindings/wasm/README.md). Incremental.
#
# Usage: scripts/build-wasm.sh [-j N]
# Environment: CADINTERP_WASM_SIMD=ON|OFF (default ON: -msimd128), CADINTERP_WASM_OUT and
# CADINTERP_WASM_OBJ (output and object directories, default build/wasm and build/wasm-obj).
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
jobs=2
if [ "${1:-}" = "-j" ] && [ -n "${2:-}" ]; then jobs="$2"; fi
out="${CADINTERP_WASM_OUT:-$root/build/wasm}"
obj="${CADINTERP_WASM_OBJ:-$root/build/wasm-obj}"
deps="$root/build/codec-sources"
simd="${CADINTERP_WASM_SIMD:-ON}"

for tool in emcmake emcc flatc cmake ninja; do
  command -v "$tool" >/dev/null || { echo "build-wasm: $tool not found (scripts/install-deps.sh)" >&2; exit 1; }
done

# Emscripten's JS optimizer needs acorn: Debian's node-acorn lives in /usr/share/nodejs, which
# the NodeSource node does not search.
export NODE_PATH="/usr/share/nodejs${NODE_PATH:+:$NODE_PATH}"

# The codec sources and private copies of the header-only libraries (emcc must not see the
# host's /usr/include).
"$root/scripts/fetch-codec-sources.sh" "$deps"

mkdir -p "$out"
cached() { sed -n "s/^$1:[A-Z]*=//p" "$obj/CMakeCache.txt" 2>/dev/null; }
if [ ! -f "$obj/build.ninja" ] || [ "$(cached CADINTERP_WASM_SIMD)" != "$simd" ] ||
   [ "$(cached CADINTERP_WASM_OUT)" != "$out" ]; then
  emcmake cmake -S "$root/bindings/wasm" -B "$obj" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCADINTERP_WASM_DEPS="$deps" -DFLATC="$(command -v flatc)" -DCADINTERP_WASM_OUT="$out" \
    -DCADINTERP_WASM_SIMD="$simd" >/dev/null
fi
cmake --build "$obj" -j "$jobs"
cp "$root/bindings/wasm/cadinterp.mjs" "$root/bindings/wasm/cadinterp.d.ts" "$out/"
ls -l "$out"/cadinterp_wasm.mjs "$out"/cadinterp_wasm.wasm "$out"/cadinterp.mjs
