#!/usr/bin/env bash
# Installs what is missing, builds every preset the tests use, and runs every test:
#   dev     Debug, -Werror: everything must compile warning-free
#   release the full suite (unit + property tests) and a benchmark smoke run
#   install `cmake --install` staged under build/stage, and programs built against it alone
#   asan    the full suite under AddressSanitizer + UndefinedBehaviorSanitizer
#   tsan    the tests labelled 'concurrency' under ThreadSanitizer
#   wasm    the runtime in WebAssembly: its JS API under Node against the conformance cases
#   cross   the runtime cross-compiled for Windows (run under Wine) and arm64 (under qemu-user)
#   explorer `cadinterp explore` and its page in headless Chromium, against the native runtime
#   freecad the FreeCAD example host's pytest tests (Python, FreeCAD, Gmsh, CalculiX)
#   fuzz    the libFuzzer targets (open+eval, every C ABI call, every codec) side by side for 30 s
#           (clang, ASan + UBSan), seeded from conformance and encoder outputs
set -euo pipefail
cd "$(dirname "$0")/.."
JOBS="${JOBS:-$(nproc)}"

scripts/install-deps.sh

step() { printf '\n== %s\n' "$*"; }
# Runs a Node test script with its output in LOG: prints the summary, or on failure the log's
# tail followed by each failed test's name and error (last, where a truncated view still sees it).
quiet_unless_failed() {
  local log=$1; shift
  mkdir -p "$(dirname "$log")"
  if ! "$@" >"$log" 2>&1; then
    tail -n 80 "$log"
    echo "-- failed tests:"; grep -E '^ *(not ok |error: )' "$log" | tail -n 20 || true
    echo "FAILED: $* (full log: $log)"; return 1
  fi
  grep -E '^(# |ℹ )(tests|pass|fail|skipped) ' "$log" || true
}

step "dev: build (Debug, warnings are errors)"
cmake --preset dev >/dev/null
cmake --build --preset dev -j "$JOBS"

step "release: build and run every test"
cmake --preset release >/dev/null
cmake --build --preset release -j "$JOBS"
ctest --preset release -j "$JOBS"

# Google Benchmark exits 0 when a filter matches nothing: require at least one result row.
bench_filtered() {  # BINARY FILTER [MORE OPTIONS]
  local bin=$1 filter=$2
  shift 2
  "$bin" --benchmark_filter="$filter" --benchmark_format=csv "$@" | grep -c '^"' >/dev/null ||
    { echo "$bin: no benchmark matches '$filter'" >&2; return 1; }
}

step "release: benchmark smoke runs (measure nothing, prove the benchmarks run)"
./build/release/src/core/core_bench --benchmark_min_time=0.001 >/dev/null
./build/release/src/runtime/runtime_probe_bench --benchmark_min_time=0.001 >/dev/null
./build/release/src/mapping/mapping_bench --benchmark_min_time=0.001 >/dev/null
bench_filtered ./build/release/examples/physics/physics_benchmark 'order1/1377' \
  --benchmark_min_time=0.001

step "release: optimize_bench smoke run (mesh quantities vs per-sample outputs; a 2x2x2 box)"
./build/release/src/optimize/optimize_bench --cubes=2 --benchmark_min_time=0.001 >/dev/null

step "release: builder benchmark smoke run (one 2-thread build of the refined bracket)"
bench_filtered ./build/release/src/builder/builder_bench 'BM_Build/model:1/threads:2'

step "install: consumers of a staged install (CMake package, pkg-config, static link)"
BUILD_DIR=build/release scripts/test-install.sh

step "asan: ASan + UBSan, every test"
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$JOBS"
ctest --preset asan -j "$JOBS"

step "tsan: ThreadSanitizer, concurrency tests"
cmake --preset tsan >/dev/null
cmake --build --preset tsan -j "$JOBS" --target cadinterp_concurrency_tests
ctest --preset tsan -j "$JOBS" -L concurrency

step "wasm: build the WebAssembly runtime, run its Node tests"
quiet_unless_failed build/wasm-test.log scripts/test-wasm.sh

step "cross: the runtime on Windows (MinGW-w64, Wine) and arm64 (qemu-user), conformance + unit tests"
scripts/test-cross.sh all

step "explorer: the web page in headless Chromium against the native runtime"
BUILD_DIR=build/release quiet_unless_failed build/explorer-test.log scripts/test-explorer.sh

step "freecad: the FreeCAD host's pytest (FreeCAD, Gmsh, CalculiX; a small build via bindings/python)"
CADINTERP_REQUIRE_ALL=1 PYTHONPATH=build/release/bindings/python /usr/bin/python3 -m pytest -q \
  -p no:cacheprovider examples/hosts/freecad/tests

step "fuzz: fuzz_open_eval, fuzz_api, fuzz_codecs for 30 s"
# Quiet on success; on failure the failing target's log tail and its input (scripts/fuzz.sh).
mkdir -p build
if ! scripts/fuzz.sh 30 >build/fuzz.log 2>&1; then
  sed -n '/^== /,$p' build/fuzz.log
  exit 1
fi
tail -n 3 build/fuzz.log
