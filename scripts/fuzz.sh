#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan+UBSan, coverage instrumentation) and runs each for
# SECONDS (default 60), all at once, so the wall time is SECONDS whatever the number of targets:
#   fuzz_open_eval  bytes through open + eval + grad + vjp + properties (the C ABI)
#   fuzz_api        every query and evaluation call of the C ABI, with invariant checks
#   fuzz_codecs     every codec decoder directly, with encode/decode round trips
# Seeds: the conformance assets (fuzz_open_eval, fuzz_api), encoder output written by
# fuzz_codecs itself, and src/runtime/fuzz_regressions/TARGET-* (inputs that once failed).
# Corpora grow in BUILD/corpus/TARGET across runs; crashes are written to
# BUILD/artifacts/TARGET-*, and a failing target's log tail and input are printed.
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]   (BUILD: $CADINTERP_FUZZ_BUILD_DIR or build/fuzz)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_open_eval fuzz_api fuzz_codecs)
build="${CADINTERP_FUZZ_BUILD_DIR:-build/fuzz}"
scripts/install-deps.sh
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCADINTERP_FUZZ=ON -DCADINTERP_SANITIZE=address,undefined \
  -DCADINTERP_BUILD_TESTING=OFF -DCADINTERP_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$build" --target "${targets[@]}" -j "$(nproc)"

binary() {
  case "$1" in
    fuzz_codecs) echo "$build/src/format/fuzz_codecs" ;;
    *) echo "$build/src/runtime/$1" ;;
  esac
}

mkdir -p "$build/artifacts" "$build/logs"
pids=()
for t in "${targets[@]}"; do
  corpus="$build/corpus/$t"
  mkdir -p "$corpus"
  case "$t" in
    fuzz_codecs)
      CADINTERP_FUZZ_WRITE_SEEDS="$corpus" "$(binary "$t")" 2>/dev/null
      max_len=32768 ;;
    *)
      for f in conformance/cases/*/*/asset.cadi; do cp "$f" "$corpus/$(echo "$f" | tr / _)"; done
      max_len=300000 ;;
  esac
  # Inputs that once failed run first, with the rest of the corpus.
  for f in src/runtime/fuzz_regressions/"$t"-*; do [ -f "$f" ] && cp "$f" "$corpus/"; done
  "$(binary "$t")" "$corpus" -max_total_time="$seconds" -max_len="$max_len" -rss_limit_mb=2048 \
    -timeout=60 -artifact_prefix="$build/artifacts/$t-" -print_final_stats=1 \
    >"$build/logs/$t.log" 2>&1 &
  pids+=($!)
done

status=0
summary=()
for i in "${!targets[@]}"; do
  t="${targets[$i]}"
  log="$build/logs/$t.log"
  if wait "${pids[$i]}"; then
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log")
    summary+=("$t ${runs:-?} runs (${rate:-?}/s)")
  else
    status=1
    summary+=("$t FAILED")
    echo "== $t failed; end of $log:"
    tail -n 40 "$log"
    # The input itself, so that a failure on a machine whose build tree is gone can be replayed:
    # base64 -d | gunzip > crash; $(binary "$t") crash
    for a in "$build/artifacts/$t"-*; do
      [ -f "$a" ] || continue
      encoded=$(gzip -9c "$a" | base64 -w 100)
      if [ "${#encoded}" -le 65536 ]; then
        echo "== $(basename "$a") ($(stat -c %s "$a") bytes), gzip | base64:"
        echo "$encoded"
        echo "== end of $(basename "$a")"
      else
        echo "== $(basename "$a"): $(stat -c %s "$a") bytes, too large to print"
      fi
    done
  fi
done
joined=$(printf '%s, ' "${summary[@]}")
joined="${joined%, }"
if [ "$status" -eq 0 ]; then
  echo "fuzz: ${seconds}s each, no crash: $joined"
else
  echo "fuzz: FAILED: $joined (artifacts in $build/artifacts)"
fi
exit "$status"
