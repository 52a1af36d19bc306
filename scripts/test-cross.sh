#!/usr/bin/env bash
# Cross-compiles the runtime with the runtime-only configure and runs it where the target is
# emulated (docs/portability.md):
#   windows  MinGW-w64 (x86_64, posix threads): libcadinterp.dll, its import library and the
#            conformance runner; the codec libraries compiled from Debian's source packages
#            (scripts/fetch-codec-sources.sh). Checks that the DLL exports the C ABI alone, then
#            runs the conformance suite under Wine.
#   arm64    aarch64-linux-gnu against the multiarch :arm64 packages: the runtime, the conformance
#            suite, the runtime's and the codecs' unit tests, all under qemu-aarch64. The portable
#            kernels are what runs there.
# Incremental: build trees and the Wine prefix stay under build/ and are reused.
#
# Usage: scripts/test-cross.sh [windows|arm64|all]   (default all)
# Environment: JOBS (default nproc). Prints one result line per platform at the end.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
what="${1:-all}"
jobs="${JOBS:-$(nproc)}"
cases="$root/conformance/cases"
case "$what" in
  windows | arm64 | all) ;;
  *) echo "usage: $0 [windows|arm64|all]" >&2; exit 2 ;;
esac
if command -v ccache >/dev/null; then
  export CMAKE_C_COMPILER_LAUNCHER=ccache CMAKE_CXX_COMPILER_LAUNCHER=ccache
fi
results=()

need() {
  for tool in "$@"; do
    command -v "$tool" >/dev/null || { echo "test-cross: $tool not found (scripts/install-deps.sh)" >&2; exit 1; }
  done
}

# Configures DIR with the given cache arguments unless it already was with exactly these (a
# stamp file holds them); cmake re-runs by itself when a CMakeLists.txt changes.
configure() {
  local dir=$1
  shift
  local args="$*"
  if [ ! -f "$dir/build.ninja" ] || [ "$(cat "$dir/.cadinterp-configure" 2>/dev/null)" != "$args" ]; then
    cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCADINTERP_WERROR=ON \
      -DCADINTERP_BUILD_BUILDER=OFF -DCADINTERP_BUILD_BENCHMARKS=OFF "$@" >"$dir.configure.log" 2>&1 ||
      { cat "$dir.configure.log"; exit 1; }
    echo "$args" >"$dir/.cadinterp-configure"
  fi
}

# "conformance: N passed, M failed" -> "N/(N+M)"
conformance_score() {
  sed -n 's/^conformance: \([0-9]*\) passed, \([0-9]*\) failed$/\1 \2/p' "$1" |
    awk '{ printf "%d/%d", $1, $1 + $2 }'
}

run_windows() {
  need x86_64-w64-mingw32-g++-posix x86_64-w64-mingw32-objdump wine
  local dir="$root/build/cross-windows"
  mkdir -p "$dir"
  "$root/scripts/fetch-codec-sources.sh" "$root/build/codec-sources"
  # bin/: the DLL beside the programs, where Windows looks for it.
  configure "$dir" -DCMAKE_TOOLCHAIN_FILE="$root/cmake/toolchains/mingw-w64.cmake" \
    -DCADINTERP_BUILD_TESTING=OFF -DCADINTERP_CODEC_SOURCES="$root/build/codec-sources" \
    -DCMAKE_RUNTIME_OUTPUT_DIRECTORY="$dir/bin"
  cmake --build "$dir" -j "$jobs" --target cadinterp cadinterp-conformance

  # The DLL's export table holds the C ABI and nothing else (runtime_exports checks the ELF one).
  local exports bad
  exports=$(x86_64-w64-mingw32-objdump -p "$dir/bin/libcadinterp.dll" |
    sed -n '/\[Ordinal\/Name Pointer\] Table/,/^$/s/^[[:space:]]*\[ *[0-9]*\] //p')
  bad=$(grep -v '^cadinterp_' <<<"$exports" || true)
  if [ -n "$bad" ] || [ -z "$exports" ]; then
    echo "test-cross: libcadinterp.dll exports unexpected symbols: ${bad:-none at all}" >&2
    exit 1
  fi
  echo "libcadinterp.dll exports $(wc -l <<<"$exports") cadinterp_* functions and nothing else"

  # A private prefix, created once. No Mono or Gecko (their installers would wait for a click);
  # timeouts, so that a Wine that hangs fails this step instead of stalling CI.
  export WINEPREFIX="$root/build/wine-prefix" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml="
  if [ ! -f "$WINEPREFIX/system.reg" ]; then
    local start=$SECONDS
    timeout 300 wineboot -i >/dev/null 2>&1
    echo "wine prefix created in $((SECONDS - start)) s"
  fi
  local log="$dir/conformance.log" rc=0
  timeout 600 wine "$dir/bin/cadinterp-conformance.exe" "$cases" >"$log" 2>&1 || rc=$?
  tr -d '\r' <"$log" >"$log.tmp" && mv "$log.tmp" "$log"
  grep -E '^(FAIL|conformance:)' "$log" || true
  if [ "$rc" != 0 ]; then
    echo "test-cross: the conformance runner failed under Wine (exit $rc; log: $log)" >&2
    exit 1
  fi
  # File names outside the ANSI code page: the runtime takes UTF-8 and opens through UTF-16
  # (src/format/mapped_file_win32.cpp). Two cases under such names must pass as well.
  local utf8="$dir/utf8-cases"
  rm -rf "$utf8" && mkdir -p "$utf8/valid" "$utf8/invalid"
  cp -r "$cases/valid/k1_linear" "$utf8/valid/k1_linear_äø€日本"
  cp -r "$cases/invalid/empty" "$utf8/invalid/empty_ß✓"
  timeout 120 wine "$dir/bin/cadinterp-conformance.exe" "$utf8" >"$log.utf8" 2>&1 ||
    { tr -d '\r' <"$log.utf8"; echo "test-cross: non-ASCII file names failed under Wine" >&2; exit 1; }
  echo "non-ASCII file names: $(tr -d '\r' <"$log.utf8" | grep '^conformance:')"
  results+=("windows-x86_64 (MinGW-w64, $(wine --version 2>/dev/null)): conformance $(conformance_score "$log") passed")
}

run_arm64() {
  need aarch64-linux-gnu-g++ qemu-aarch64
  local p
  for p in libzstd-dev libdraco-dev libmeshoptimizer-dev libgtest-dev libxxhash-dev libflatbuffers-dev; do
    dpkg-query -W -f='${Status}' "$p:arm64" 2>/dev/null | grep -q "install ok installed" ||
      { echo "test-cross: $p:arm64 is not installed (scripts/install-deps.sh)" >&2; exit 1; }
  done
  local dir="$root/build/cross-arm64"
  mkdir -p "$dir"
  configure "$dir" -DCMAKE_TOOLCHAIN_FILE="$root/cmake/toolchains/aarch64-linux-gnu.cmake" \
    -DCADINTERP_BUILD_TESTING=ON
  # The runtime's tests and the codecs' (decoding on arm64); core's property tests take minutes
  # under emulation and exercise nothing platform-specific the runtime tests do not. No thread
  # tests: Debian 12's qemu-user hangs creating a thread here (docs/portability.md, "Known limits").
  local tests=(src/runtime/runtime_tests src/runtime/runtime_element_queries_tests
    src/runtime/runtime_names_tests
    src/runtime/runtime_alloc_tests src/runtime/runtime_blend_tests
    src/runtime/runtime_metrics_tests src/format/codec_tests)
  cmake --build "$dir" -j "$jobs" --target cadinterp cadinterp-conformance runtime_api_c99_test \
    "${tests[@]##*/}"
  local qemu=(qemu-aarch64 -L /usr/aarch64-linux-gnu)
  local log="$dir/conformance.log"
  "${qemu[@]}" "$dir/conformance/cadinterp-conformance" "$cases" >"$log" 2>&1 ||
    { cat "$log"; echo "test-cross: the conformance runner failed under qemu (log: $log)" >&2; exit 1; }
  grep -E '^(FAIL|conformance:)' "$log" || true
  "${qemu[@]}" "$dir/src/runtime/runtime_api_c99_test" >/dev/null
  # OpenRefusesFifosAndDirectoriesWithoutBlocking opens in a second thread (see above); the
  # reader's FIFO refusal is the same POSIX code the native run tests.
  local passed=0 t tlog n
  for t in "${tests[@]}"; do
    tlog="$dir/${t##*/}.log"
    if ! timeout 300 "${qemu[@]}" "$dir/$t" --gtest_brief=1 \
      --gtest_filter=-Runtime.OpenRefusesFifosAndDirectoriesWithoutBlocking >"$tlog" 2>&1; then
      tail -n 40 "$tlog"
      echo "test-cross: ${t##*/} failed under qemu (log: $tlog)" >&2
      exit 1
    fi
    n=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) tests\{0,1\}\.$/\1/p' "$tlog" | head -1)
    passed=$((passed + ${n:-0}))
  done
  echo "arm64: runtime_api_c99_test and ${#tests[@]} GoogleTest programs, $passed tests passed"
  results+=("linux-arm64 (qemu-aarch64): conformance $(conformance_score "$log") passed, $passed runtime and codec unit tests passed")
}

start=$SECONDS
if [ "$what" = windows ] || [ "$what" = all ]; then run_windows; fi
if [ "$what" = arm64 ] || [ "$what" = all ]; then run_arm64; fi
echo "-- cross results ($((SECONDS - start)) s):"
printf '  %s\n' "${results[@]}"
