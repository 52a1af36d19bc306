#!/usr/bin/env bash
# Builds the WebAssembly runtime if needed (incremental) and runs its Node tests: the
# conformance cases, the API against finite differences and mesh sums, leaks.
# Usage: scripts/test-wasm.sh [extra node --test arguments]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/scripts/build-wasm.sh" >/dev/null
cd "$root"
node --test "$@" bindings/wasm/test/
