#!/usr/bin/env bash
# Builds the libFuzzer target for open+eval (clang, ASan+UBSan, coverage instrumentation) and
# runs it for SECONDS (default 60), seeded with the conformance assets. Crashes are written to
# build/fuzz/artifacts/. Usage: scripts/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
scripts/install-deps.sh
cmake -S . -B build/fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCADINTERP_FUZZ=ON -DCADINTERP_SANITIZE=address,undefined \
  -DCADINTERP_BUILD_TESTS=OFF -DCADINTERP_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build build/fuzz --target fuzz_open_eval -j "$(nproc)"
corpus=build/fuzz/corpus
mkdir -p "$corpus" build/fuzz/artifacts
for f in conformance/cases/*/*/asset.cadi; do cp "$f" "$corpus/$(echo "$f" | tr / _)"; done
build/fuzz/src/runtime/fuzz_open_eval "$corpus" -max_total_time="$seconds" -max_len=300000 -rss_limit_mb=2048 \
  -artifact_prefix=build/fuzz/artifacts/ -print_final_stats=1
