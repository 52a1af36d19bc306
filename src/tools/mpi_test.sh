#!/usr/bin/env bash
# `cadinterp build --mpi` under mpirun on this machine (ctest label "mpi"), one case per call:
#   identical  3 ranks (--oversubscribe): the asset is byte-identical to the threaded build, with
#              simulate requests (--simulate-mapped) crossing the ranks too
#   resume     a host rank killed mid-build (analytic kill_after): the job stops, rank 0 reports
#              what it accepted; a rerun without the fault evaluates exactly the points the store
#              lacks and writes the uninterrupted build's bytes
#   bad_use    one rank (refused: rank 0 does not run the host), ranks with different hosts
# usage: mpi_test.sh CADINTERP MPIEXEC ANALYTIC_SO WORK_DIR CASE
set -u
CLI=$1 MPIEXEC=$2 HOST_SO=$3 WORK=$4 CASE=$5
rm -rf "$WORK" && mkdir -p "$WORK" && cd "$WORK" || exit 1

# CI runs as root, which Open MPI refuses unless told; containers also forbid the ptrace-based
# single-copy transfer of its shared-memory transport.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none
mpi() { "$MPIEXEC" --oversubscribe -np "$@"; }

fail() {
  echo "FAIL: $*"
  for f in *.out *.err; do [ -s "$f" ] && { echo "--- $f"; cat "$f"; }; done
  exit 1
}
# The number after "$2" on the summary line of file $1.
count() { sed -n "s/.*$2 \([0-9][0-9]*\).*/\1/p" "$1" | head -1; }

case $CASE in
identical)
  opts=(build --host "$HOST_SO" --model plate --host-options edge=10 --simulate-mapped
    --max-samples 16 --max-depth 2 -q)
  "$CLI" "${opts[@]}" --threads 2 -o ref.cadi >ref.out 2>ref.err || fail "threaded build"
  mpi 3 "$CLI" "${opts[@]}" --mpi -o mpi.cadi >mpi.out 2>mpi.err || fail "mpirun -np 3 build"
  cmp ref.cadi mpi.cadi || fail "the MPI asset differs from the threaded build's"
  grep -q "mpi  *2 host ranks" mpi.out || fail "no MPI summary line"
  evals=$(count mpi.out "host evaluations")
  [ "$evals" = "$(count ref.out "host evaluations")" ] || fail "host evaluations differ"
  # Answers = samples + simulations on mapped meshes: the simulate requests crossed the ranks.
  answers=$(sed -n 's/.* \([0-9][0-9]*\) answers from them.*/\1/p' mpi.out)
  [ "${answers:-0}" -gt "$evals" ] || fail "no simulate request went to a rank ($answers answers)"
  ;;
resume)
  opts=(build --host "$HOST_SO" --model bracket --max-samples 24 --max-depth 2 -q)
  "$CLI" "${opts[@]}" --host-options cells=1 --threads 2 -o ref.cadi >ref.out 2>ref.err ||
    fail "threaded build"
  points=$(count ref.out "host evaluations")
  # Each host rank kills itself at its 5th regenerate: the job ends with 8 or fewer samples in.
  mpi 3 "$CLI" "${opts[@]}" --host-options cells=1,kill_after=4 --mpi --store s.db \
    -o a.cadi >kill.out 2>kill.err && fail "the job with a dying rank succeeded"
  grep -q "stopped by SIGTERM" kill.err || fail "rank 0 did not stop cleanly on SIGTERM"
  accepted=$(sed -n 's/.*; \([0-9][0-9]*\) answers from the ranks were accepted.*/\1/p' kill.err)
  [ "${accepted:-0}" -gt 0 ] || fail "no samples accepted before the kill"
  [ -e a.cadi ] && fail "an asset was written by the stopped job"
  mpi 3 "$CLI" "${opts[@]}" --host-options cells=1 --mpi --store s.db -o a.cadi \
    >rerun.out 2>rerun.err || fail "the rerun"
  hits=$(count rerun.out "from the store") evals=$(count rerun.out "host evaluations")
  echo "uninterrupted: $points host evaluations; killed run: $accepted accepted;" \
    "rerun: $hits from the store, $evals host evaluations"
  [ "$hits" = "$accepted" ] || fail "the store kept $hits samples, rank 0 accepted $accepted"
  [ $((hits + evals)) = "$points" ] || fail "rerun: $hits + $evals != $points points"
  cmp ref.cadi a.cadi || fail "the resumed asset differs from the uninterrupted build's"
  ;;
bad_use)
  mpi 1 "$CLI" build --mpi --host "$HOST_SO" -o one.cadi >one.out 2>one.err &&
    fail "--mpi with one rank was accepted"
  grep -q -- "--mpi needs at least 2 ranks" one.err || fail "one rank: no clear message"
  # MPMD: rank 1 loads another model; rank 0 must refuse before any request.
  "$MPIEXEC" --oversubscribe -np 1 "$CLI" build --mpi --host "$HOST_SO" -o two.cadi : \
    -np 1 "$CLI" build --mpi --host "$HOST_SO" --model plate -o two.cadi >two.out 2>two.err &&
    fail "ranks with different hosts were accepted"
  grep -q "every rank must load the same host" two.err || fail "different hosts: no clear message"
  grep -q "rank 1 loaded analytic .analytic plate" two.err || fail "different hosts: the rank is not named"
  ;;
*)
  echo "unknown case $CASE"
  exit 2
  ;;
esac
echo "PASS: $CASE"
