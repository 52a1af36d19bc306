#!/usr/bin/env bash
# WebAssembly vs native eval speed, in the same run, on runtime_bench's 100k-vertex K=3 fixture
# (bindings/wasm/bench/): builds the WASM module (scripts/build-wasm.sh) and the native runtime
# (build/h-wasm-native), writes the asset once, times both, prints both and the ratios.
# Goal: WASM eval <= 2x native.
#
# Usage: scripts/bench-wasm.sh [N]     N: calls per measurement (default 200)
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
n="${1:-200}"
native="$root/build/h-wasm-native"
work="$root/build/wasm-bench"
mkdir -p "$work"

"$root/scripts/build-wasm.sh" >/dev/null

if [ ! -f "$native/build.ninja" ]; then
  cmake -S "$root" -B "$native" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCADINTERP_BUILD_BENCHMARKS=OFF \
    -DCADINTERP_WITH_PHYSICS=OFF -DCADINTERP_WITH_OCCT=OFF \
    -DCADINTERP_WITH_EXPLORER=OFF >/dev/null
fi
cmake --build "$native" --target cadinterp cadinterp_format -j2 >/dev/null

# The tool links the static format library (the synthetic asset writer) and the C ABI of the
# shared runtime, as runtime_bench does; built outside CMake, the top-level tree not being ours.
tool="$work/bench_native"
src="$root/bindings/wasm/bench/bench_native.cpp"
libs=("$native/src/format/libcadinterp_format.a" "$native/src/format/libcadinterp_codecs.a"
      "$native/src/core/libcadinterp_core.a" "$native/src/runtime/libcadinterp.so")
if [ ! -x "$tool" ] || [ "$src" -nt "$tool" ] || [ "${libs[0]}" -nt "$tool" ] || [ "${libs[3]}" -nt "$tool" ]; then
  g++ -std=c++17 -O2 -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion -I"$root/src" -I"$root/include" -I"$native/src/format/generated" \
    "$src" "${libs[@]}" -Wl,-rpath,"$native/src/runtime" \
    $(pkg-config --libs libxxhash libzstd) -lmeshoptimizer -ldraco -lpthread -o "$tool"
fi

asset="$work/box_100k_k3.cadi"
if [ ! -f "$asset" ] || [ "$tool" -nt "$asset" ]; then
  echo "writing $asset ..."
  "$tool" write "$asset"
fi

nat="$("$tool" time "$asset" "$n")"
was="$(node "$root/bindings/wasm/bench/bench.mjs" "$root/build/wasm" "$asset" "$n")"
echo "asset:  $asset ($(stat -c %s "$asset") bytes)"
echo "native: $nat"
echo "wasm:   $was"
node -e '
const nat = JSON.parse(process.argv[1]), was = JSON.parse(process.argv[2]);
const keys = ["eval_ms", "eval_field_ms", "grad_ms", "vjp_ms", "properties_ms", "first_eval_ms"];
console.log("median ms per call, " + nat.vertices + " vertices, K=3");
console.log("  what             native      wasm   wasm/native");
for (const k of keys) console.log("  " + k.padEnd(14) + nat[k].toFixed(3).padStart(10) + was[k].toFixed(3).padStart(10) + (was[k] / nat[k]).toFixed(2).padStart(12));
const r = was.eval_ms / nat.eval_ms;
console.log("eval ratio " + r.toFixed(2) + " (goal <= 2): " + (r <= 2 ? "met" : "NOT met"));
' "$nat" "$was"
