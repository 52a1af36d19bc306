#!/usr/bin/env bash
# Checks that cadinterp.fbs is a compatible evolution of every released schema
# (FlatBuffers' rules: ids kept, fields appended, types unchanged), and that the check itself
# rejects an incompatible change. Usage: conform_test.sh FILEFORMAT_DIR (FLATC may name flatc).
set -euo pipefail
dir="$1"
flatc="${FLATC:-flatc}"
status=0
for released in "$dir"/released/*.fbs; do
  if "$flatc" --conform "$released" "$dir/cadinterp.fbs"; then
    echo "conforms to $(basename "$released")"
  else
    echo "FAIL: cadinterp.fbs breaks $(basename "$released")"; status=1
  fi
done
# The test-only schema of the forward-compatibility cases (conformance/future) must be an
# evolution of this one; flatc compares by qualified names, so its namespace is mapped first.
future="$(mktemp --suffix=.fbs)"
broken="$(mktemp --suffix=.fbs)"
trap 'rm -f "$broken" "$future"' EXIT
sed 's/^namespace cadinterp.future_fb;/namespace cadinterp.fb;/' \
  "$dir/../conformance/future/cadinterp_future.fbs" > "$future"
if "$flatc" --conform "$dir/cadinterp.fbs" "$future"; then
  echo "conformance/future/cadinterp_future.fbs conforms to cadinterp.fbs"
else
  echo "FAIL: conformance/future/cadinterp_future.fbs breaks cadinterp.fbs"; status=1
fi
# Negative control: renumbering a field must be refused.
sed 's/lower: double (id: 2);/lower: double (id: 4);/; s/upper: double (id: 3);/upper: double (id: 2);/' \
  "$dir/cadinterp.fbs" > "$broken"
if "$flatc" --conform "$dir/released/1.0.fbs" "$broken" >/dev/null 2>&1; then
  echo "FAIL: flatc --conform accepted a renumbered field"; status=1
else
  echo "negative control rejected as expected"
fi
exit $status
