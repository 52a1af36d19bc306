#!/usr/bin/env bash
# Regenerates abi/libcadinterp.abi, the runtime ABI baseline the abi_check ctest compares every
# release build with (abi/README.md). Run it only when a release deliberately extends the ABI
# (or, after an incompatible change, together with a new CADINTERP_ABI_VERSION), and commit
# the result with the change. Builds the release preset's libcadinterp first.
# Usage: scripts/update-abi-baseline.sh
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
cmake --preset release >/dev/null
cmake --build --preset release --target cadinterp
# The library the build just linked (the namelink's target), never a stale file of an older
# ABI version left in the build tree.
lib="$(readlink -f build/release/src/runtime/libcadinterp.so)"
bash abi/abi.sh dump "$lib" include/cadinterp abi/libcadinterp.abi
echo "wrote abi/libcadinterp.abi from $lib ($(grep -c '<elf-symbol ' abi/libcadinterp.abi) symbols)"
git --no-pager diff --stat -- abi/libcadinterp.abi || true
