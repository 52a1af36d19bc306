#!/usr/bin/env bash
# The runtime ABI's baseline and check (abi/README.md), with libabigail.
#   abi.sh dump LIB HEADERS_DIR OUT       writes LIB's ABI (public headers' view) to OUT
#   abi.sh check BASELINE LIB HEADERS_DIR compares LIB with BASELINE under the policy below
# Policy: additions are compatible (new functions, variables; abidiff bit 4 from them only);
# any other difference fails: a removed or changed function or variable (bit 8,
# ABIDIFF_ABI_INCOMPATIBLE_CHANGE) and also a change to a type an existing function reaches
# (bit 4 with additions ignored), since abidiff reports a public struct's changed layout with
# bit 4 only. Exit status of check: 0 compatible, 1 incompatible, 2 tool error, 77 (ctest's
# skip) when libabigail is not installed.
set -euo pipefail

# Flags that make the dump depend on the public ABI only: types declared outside the public
# headers are dropped, only exported interfaces are read, and no path, location, DT_NEEDED list
# or sequence-numbered type id (which shifts when anything is added) is written. The translation
# unit's path is removed too: it is relative or absolute depending on ccache's base_dir.
dump() {
  abidw --headers-dir "$2" --drop-private-types --exported-interfaces-only --no-corpus-path \
    --no-comp-dir-path --no-show-locs --no-elf-needed --type-id-style hash "$1" |
    sed -E "s/^( *<abi-instr [^>]*) path='[^']*'/\1/" >"$3"
}

case "${1:-}" in
dump)
  [ $# -eq 4 ] || { echo "usage: $0 dump LIB HEADERS_DIR OUT" >&2; exit 2; }
  dump "$2" "$3" "$4"
  ;;
check)
  [ $# -eq 4 ] || { echo "usage: $0 check BASELINE LIB HEADERS_DIR" >&2; exit 2; }
  if ! command -v abidiff >/dev/null || ! command -v abidw >/dev/null; then
    echo "SKIP: abidiff/abidw not found (Debian: apt-get install abigail-tools;"
    echo "scripts/install-deps.sh installs it, so CI always runs this check)"
    exit 77
  fi
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  dump "$3" "$4" "$tmp/current.abi"
  set +e
  abidiff "$2" "$tmp/current.abi" >"$tmp/full.txt"
  full=$?
  abidiff --no-added-syms "$2" "$tmp/current.abi" >"$tmp/changes.txt"
  rc=$?
  set -e
  if ((full & 3)); then
    cat "$tmp/full.txt"
    echo "abidiff failed (exit $full)"
    exit 2
  fi
  if ((rc == 0)); then
    if ((full == 0)); then echo "ABI identical to $(basename "$2")"; else
      cat "$tmp/full.txt"
      echo "ABI compatible with $(basename "$2"): additions only (abidiff exit $full)"
    fi
    exit 0
  fi
  cat "$tmp/changes.txt"
  if ((rc & 8)); then
    echo "ABI INCOMPATIBLE with $(basename "$2") (abidiff exit $rc: ABIDIFF_ABI_INCOMPATIBLE_CHANGE)"
  else
    echo "ABI CHANGED against $(basename "$2") beyond additions (abidiff exit $rc): a released"
    echo "declaration or a type it reaches changed; the frozen ABI grows by addition only"
  fi
  exit 1
  ;;
*)
  echo "usage: $0 dump LIB HEADERS_DIR OUT | check BASELINE LIB HEADERS_DIR" >&2
  exit 2
  ;;
esac
