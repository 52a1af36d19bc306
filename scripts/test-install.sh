#!/usr/bin/env bash
# Consumer tests against a staged install, not the build tree:
#   DESTDIR=build/stage cmake --install BUILD_DIR     (BUILD_DIR: build/release unless set)
# then, with nothing of BUILD_DIR on any path,
#   (a) the out-of-tree CMake project examples/consumer: find_package(cadinterp MAJOR.MINOR
#       REQUIRED) with this tree's own version, linked shared (cadinterp::runtime), static
#       (cadinterp::runtime_static, plus the full conformance runner) and to the builder;
#   (b) a plain `cc $(pkg-config --cflags --libs cadinterp)` build of examples/consumer/consumer.c;
#   (c) a static link through `pkg-config --static` (libcadinterp.a chosen with -l:);
#   (d) the installed `cadinterp` tool: a small build with its built-in host, then eval.
# Each consumer evaluates every valid conformance case against its expected values, and says
# which file the runtime code came from: the staged libcadinterp.so, or itself when static. The
# consumer is also run on a case with one changed expected value, which it must reject.
# Prints the installed files and the sizes of the static runtime and of the consumers.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BUILD=$(cd "${BUILD_DIR:-build/release}" && pwd)
STAGE=$ROOT/build/stage
OUT=$ROOT/build/consumer
SECONDS=0

fail() { echo "FAILED: $*" >&2; exit 1; }
cache() { sed -n "s/^$1:[A-Z]*=//p" "$BUILD/CMakeCache.txt"; }

rm -rf "$STAGE" "$OUT"
mkdir -p "$OUT"
DESTDIR=$STAGE cmake --install "$BUILD" >"$OUT/install.log"
PREFIX=$STAGE$(cache CMAKE_INSTALL_PREFIX)
LIBDIR=$PREFIX/$(cache CMAKE_INSTALL_LIBDIR)
[ -f "$LIBDIR/libcadinterp.a" ] || fail "no libcadinterp.a in $LIBDIR"

# The package must be relocatable and must not point back into the build or source tree.
if grep -rl -e "$BUILD" -e "$ROOT/src" -e "$ROOT/include" "$LIBDIR/cmake" "$LIBDIR/pkgconfig"; then
  fail "installed package files name the build or source tree"
fi
for f in "$LIBDIR"/libcadinterp*.so.*.* "$PREFIX/bin/cadinterp" "$PREFIX/bin/cadinterp-host-worker"; do
  [ -e "$f" ] || continue
  if readelf -d "$f" | grep -E 'R(UN)?PATH' | grep -q "$ROOT"; then
    fail "$f has an RPATH into the build tree: $(readelf -d "$f" | grep -E 'R(UN)?PATH')"
  fi
done

# This tree's MAJOR.MINOR: find_package asks for exactly the version being installed.
VERSION_H=include/cadinterp/cadinterp_version.h
MAJOR=$(sed -n 's/^#define CADINTERP_VERSION_MAJOR \([0-9]*\)/\1/p' "$VERSION_H")
MINOR=$(sed -n 's/^#define CADINTERP_VERSION_MINOR \([0-9]*\)/\1/p' "$VERSION_H")
CASES=("$ROOT"/conformance/cases/valid/*)

# run_consumer EXE WANT: runs EXE on every valid case with only the stage on the library path;
# WANT is the file the runtime must come from ("stage": the staged libcadinterp.so.N, "self":
# the executable itself, a static link).
run_consumer() {
  local exe=$1 want=$2 from
  LD_LIBRARY_PATH=$LIBDIR "$exe" "${CASES[@]}" >"$exe.out" 2>&1 ||
    { cat "$exe.out"; fail "$exe on the conformance cases"; }
  from=$(sed -n 's/^runtime .* from //p' "$exe.out")
  if readelf -d "$exe" | grep -E 'R(UN)?PATH' | grep -q "$BUILD"; then
    fail "$exe has an RPATH into the build tree"
  fi
  case $want in
    stage) [[ $from == "$LIBDIR"/libcadinterp.so.* ]] || fail "$exe loaded the runtime from $from" ;;
    self) [ "$from" -ef "$exe" ] || fail "$exe (static) took the runtime from $from"
          ! ldd "$exe" | grep -q libcadinterp || fail "$exe (static) needs a shared libcadinterp" ;;
  esac
  if [ "$want" = stage ] && LD_LIBRARY_PATH=$LIBDIR ldd "$exe" | grep libcadinterp | grep -qv "$STAGE"; then
    fail "$exe resolves libcadinterp outside the stage: $(ldd "$exe" | grep libcadinterp)"
  fi
  echo "$(basename "$exe"): $(tail -n 1 "$exe.out"), runtime from ${from#"$ROOT"/}"
}

echo "-- (a) CMake: find_package(cadinterp $MAJOR.$MINOR REQUIRED)"
cmake -S examples/consumer -B "$OUT/cmake" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$PREFIX" -DCADINTERP_REQUIRED_VERSION="$MAJOR.$MINOR" \
  -DCADINTERP_CONFORMANCE_RUNNER="$ROOT/conformance/runner.cpp" >"$OUT/cmake.log" ||
  { cat "$OUT/cmake.log"; fail "configuring examples/consumer"; }
grep -q "^-- cadinterp $MAJOR\.$MINOR\.[0-9]* from $LIBDIR/cmake/cadinterp\$" "$OUT/cmake.log" ||
  fail "find_package did not take the staged package: $(grep '^-- cadinterp' "$OUT/cmake.log")"
cmake --build "$OUT/cmake" >"$OUT/cmake-build.log" || { cat "$OUT/cmake-build.log"; fail "build"; }
run_consumer "$OUT/cmake/consumer_shared" stage
run_consumer "$OUT/cmake/consumer_static" self
"$OUT/cmake/conformance_static" conformance/cases >"$OUT/conformance_static.out" ||
  { grep FAIL "$OUT/conformance_static.out"; fail "conformance runner, static link"; }
echo "conformance_static: $(tail -n 1 "$OUT/conformance_static.out")"
if [ -x "$OUT/cmake/builder_consumer" ]; then
  LD_LIBRARY_PATH=$LIBDIR "$OUT/cmake/builder_consumer" | tail -n 1
fi

# The comparison can fail: one expected position changed in a copy of a case.
BAD=$OUT/changed_case
cp -r conformance/cases/valid/k2_linear "$BAD"
awk '/^positions/ && !done { $2 = "0x1p+3"; done = 1 } { print }' \
  conformance/cases/valid/k2_linear/expected.txt >"$BAD/expected.txt"
if LD_LIBRARY_PATH=$LIBDIR "$OUT/cmake/consumer_shared" "$BAD" >"$OUT/changed_case.out" 2>&1 ||
  ! grep -q "positions\[0\]: got 0, expected 8" "$OUT/changed_case.out"; then
  cat "$OUT/changed_case.out"; fail "the consumer accepted a changed expected value"
fi
echo "changed expected value: rejected ($(grep -m1 'positions\[' "$OUT/changed_case.out" | sed 's/^ *//'))"

echo "-- (b) cc \$(pkg-config --cflags --libs cadinterp)"
export PKG_CONFIG_SYSROOT_DIR=$STAGE PKG_CONFIG_PATH=$LIBDIR/pkgconfig
CFLAGS_C99=(-std=c99 -O2 -Wall -Wextra -Wpedantic -Werror)
# shellcheck disable=SC2046  # pkg-config's output is a list of flags
cc "${CFLAGS_C99[@]}" examples/consumer/consumer.c $(pkg-config --cflags --libs cadinterp) \
  -o "$OUT/pc_shared"
run_consumer "$OUT/pc_shared" stage

echo "-- (c) static: pkg-config --static, libcadinterp.a by -l:"
LIBS=" $(pkg-config --static --libs cadinterp) "
# shellcheck disable=SC2046,SC2086
cc "${CFLAGS_C99[@]}" -DCADINTERP_STATIC examples/consumer/consumer.c \
  $(pkg-config --cflags cadinterp) ${LIBS/ -lcadinterp / -l:libcadinterp.a } -o "$OUT/pc_static"
run_consumer "$OUT/pc_static" self
# Every object of the archive links with those flags (not only those the consumer pulls in), and
# the archive defines the whole C ABI the shared library exports.
# shellcheck disable=SC2046,SC2086
cc "${CFLAGS_C99[@]}" -DCADINTERP_STATIC examples/consumer/consumer.c \
  $(pkg-config --cflags cadinterp) ${LIBS/ -lcadinterp / -Wl,--whole-archive -l:libcadinterp.a -Wl,--no-whole-archive } \
  -o "$OUT/pc_static_whole" || fail "libcadinterp.a with --whole-archive: unresolved references"
abi() { grep -o ' T cadinterp_[a-z0-9_]*' | sort -u; }
diff <(nm -D --defined-only "$LIBDIR/libcadinterp.so" | abi) \
     <(nm --defined-only "$LIBDIR/libcadinterp.a" 2>/dev/null | abi) ||
  fail "libcadinterp.a and libcadinterp.so define different cadinterp_* functions"
echo "libcadinterp.a: links whole; defines the $(nm -D --defined-only "$LIBDIR/libcadinterp.so" | abi | wc -l) functions libcadinterp.so exports"

if [ -x "$PREFIX/bin/cadinterp" ]; then
  echo "-- (d) the installed cadinterp tool (RUNPATH \$ORIGIN, no LD_LIBRARY_PATH)"
  TOOL=$PREFIX/bin/cadinterp
  ldd "$TOOL" | grep libcadinterp | grep -qv "$STAGE" && fail "the tool loads libcadinterp outside the stage"
  "$TOOL" --version | head -n 1
  if "$TOOL" --version | grep -q 'builder: yes'; then
    "$TOOL" build --host analytic --model bracket --host-options cells=1 --max-samples 12 \
      -o "$OUT/bracket.cadi" >"$OUT/tool-build.out" 2>&1 || { cat "$OUT/tool-build.out"; fail "tool build"; }
    "$TOOL" eval "$OUT/bracket.cadi" 60 45 5.5 90 >"$OUT/tool-eval.out" 2>&1 ||
      { cat "$OUT/tool-eval.out"; fail "tool eval"; }
    grep -q '^mesh  *[1-9][0-9]* vertices' "$OUT/tool-eval.out" || fail "tool eval printed no mesh"
    echo "built: $(grep -m1 '^  elements' "$OUT/tool-build.out" | tr -s ' ' | sed 's/^ //');" \
      "eval: $(grep -m1 '^mesh' "$OUT/tool-eval.out" | tr -s ' ')"
  fi
fi

echo "-- installed files (under ${STAGE#"$ROOT"/})"
(cd "$STAGE" && find . \( -type f -o -type l \) | sort | sed 's|^\./|  /|')
echo "-- sizes (bytes)"
strip_size() { strip -o "$OUT/stripped" "$1" && stat -c %s "$OUT/stripped"; }
printf '  libcadinterp.a %s (debug info stripped: %s), libcadinterp.so %s (stripped: %s)\n' \
  "$(stat -c %s "$LIBDIR/libcadinterp.a")" \
  "$(strip --strip-debug -o "$OUT/stripped" "$LIBDIR/libcadinterp.a" && stat -c %s "$OUT/stripped")" \
  "$(stat -L -c %s "$LIBDIR/libcadinterp.so")" "$(strip_size "$LIBDIR/libcadinterp.so")"
printf '  consumer, stripped: shared-linked %s, static-linked %s\n' \
  "$(strip_size "$OUT/cmake/consumer_shared")" "$(strip_size "$OUT/cmake/consumer_static")"
echo "install consumer tests passed in ${SECONDS}s"
