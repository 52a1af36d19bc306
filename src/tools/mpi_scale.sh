#!/usr/bin/env bash
# Throughput of `cadinterp build --mpi` against the rank count (docs/distributed-builds.md): the
# same build for each rank count, with the analytic host sleeping SLEEP_MS per
# regenerate as a stand-in for minutes of CAD and FEM, so that the host dominates as it does in
# production. Prints one markdown row per rank count: samples/s, speed-up over 2 ranks (one host
# rank), rank 0's CPU time per sample (every thread: builder, store, MPI) and its busy share of
# the wall time (= CPU per sample x samples/s).
# usage: mpi_scale.sh CADINTERP ANALYTIC_SO [RANKS...]   (env: SLEEP_MS=200 MAX_SAMPLES=24 CELLS=2)
set -euo pipefail
CLI=$1 HOST_SO=$2
shift 2
RANKS=("$@")
[ ${#RANKS[@]} -gt 0 ] || RANKS=(2 3 4 5 6 7 8)
SLEEP_MS=${SLEEP_MS:-200} MAX_SAMPLES=${MAX_SAMPLES:-24} CELLS=${CELLS:-2}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

echo "| ranks | host ranks | samples | wall s | samples/s | speed-up | rank 0 CPU ms/sample | rank 0 busy |"
echo "|---|---|---|---|---|---|---|---|"
base=""
for n in "${RANKS[@]}"; do
  mpirun --oversubscribe -np "$n" "$CLI" build --mpi --host "$HOST_SO" --model bracket \
    --host-options "cells=$CELLS,sleep_ms=$SLEEP_MS" --max-samples "$MAX_SAMPLES" -q \
    -o "$WORK/a.cadi" >"$WORK/out" 2>"$WORK/err" || { cat "$WORK/err"; exit 1; }
  # "  mpi  W host ranks, S answers from them, X answers/s; rank 0 CPU C s (M ms per answer, B % busy)"
  line=$(grep "^  mpi " "$WORK/out")
  read -r w s x _ m b < <(echo "$line" | sed -E \
    's/.* ([0-9]+) host ranks, ([0-9]+) answers from them, ([0-9.]+) answers\/s; rank 0 CPU ([0-9.]+) s \(([0-9.]+) ms per answer, ([0-9.]+) % busy\).*/\1 \2 \3 \4 \5 \6/')
  wall=$(awk -v s="$s" -v x="$x" 'BEGIN { printf "%.1f", s / x }')
  [ -n "$base" ] || base=$x
  speedup=$(awk -v x="$x" -v b="$base" 'BEGIN { printf "%.2f", x / b }')
  echo "| $n | $w | $s | $wall | $x | $speedup | $m | $b % |"
done
