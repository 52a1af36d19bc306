#!/usr/bin/env bash
# Fetches the C/C++ sources of the codec libraries the runtime decodes blobs with (zstd,
# meshoptimizer, Draco) for the WebAssembly build: Debian ships them only as native libraries,
# so the Debian *source* packages of exactly the installed -dev versions are downloaded and
# unpacked into a cache outside git. Idempotent: a second run does nothing (no network).
#
# Usage: scripts/fetch-wasm-sources.sh [CACHE_DIR]     (default: build/wasm-deps)
# Prints nothing but progress; the unpacked trees are CACHE_DIR/src/{zstd,meshoptimizer,draco}.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
cache="${1:-$root/build/wasm-deps}"
mkdir -p "$cache/src" "$cache/download"

# Source package -> installed binary package whose version must match (the native build links
# the binary one; the WASM build must decode exactly what the native encoder writes).
declare -A binary_of=([libzstd]=libzstd-dev [meshoptimizer]=libmeshoptimizer-dev [draco]=libdraco-dev)
declare -A dir_of=([libzstd]=zstd [meshoptimizer]=meshoptimizer [draco]=draco)

version_of() {
  dpkg-query -W -f='${Version}\n' "$1" 2>/dev/null | head -n1 || true
}

need_fetch=0
for src in libzstd meshoptimizer draco; do
  v="$(version_of "${binary_of[$src]}")"
  if [ -z "$v" ]; then
    echo "fetch-wasm-sources: ${binary_of[$src]} is not installed (scripts/install-deps.sh)" >&2
    exit 1
  fi
  stamp="$cache/src/${dir_of[$src]}/.cadinterp-version"
  if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$v" ]; then need_fetch=1; fi
done
if [ "$need_fetch" = 0 ]; then
  echo "fetch-wasm-sources: sources up to date in $cache/src"
  exit 0
fi

# A deb-src entry mirroring the binary one (same URIs, suites, components and key).
src_list=/etc/apt/sources.list.d/debian-src.sources
if ! grep -rqs '^Types:.*deb-src' /etc/apt/sources.list.d/ /etc/apt/sources.list 2>/dev/null; then
  if [ ! -f /etc/apt/sources.list.d/debian.sources ]; then
    echo "fetch-wasm-sources: no /etc/apt/sources.list.d/debian.sources to derive a deb-src entry from" >&2
    exit 1
  fi
  sudo_cmd=()
  [ "$(id -u)" = 0 ] || sudo_cmd=(sudo)
  echo "fetch-wasm-sources: adding $src_list"
  sed 's/^Types:.*/Types: deb-src/' /etc/apt/sources.list.d/debian.sources |
    "${sudo_cmd[@]}" tee "$src_list" >/dev/null
  "${sudo_cmd[@]}" apt-get update -qq
fi

# The deb-src indexes may be missing even with the entry present (never updated since added).
if [ -z "$(apt-cache showsrc libzstd 2>/dev/null | head -1)" ]; then
  sudo_cmd=()
  [ "$(id -u)" = 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
fi

cd "$cache/download"
for src in libzstd meshoptimizer draco; do
  v="$(version_of "${binary_of[$src]}")"
  dir="$cache/src/${dir_of[$src]}"
  if [ -f "$dir/.cadinterp-version" ] && [ "$(cat "$dir/.cadinterp-version")" = "$v" ]; then
    continue
  fi
  upstream="${v#*:}"   # no epoch in file names
  dsc="$(ls "${src}_${upstream}.dsc" 2>/dev/null || true)"
  if [ -z "$dsc" ]; then
    echo "fetch-wasm-sources: apt-get source --download-only $src=$v"
    apt-get source -qq --download-only "$src=$v"
    dsc="${src}_${upstream}.dsc"
  fi
  rm -rf "$dir" "$dir.tmp"
  # No signature check needed beyond apt's: the files were verified against the signed index.
  dpkg-source --no-check -x "$dsc" "$dir.tmp" >/dev/null
  mv "$dir.tmp" "$dir"
  rm -f "$cache/src/"*.orig.tar.* "$cache/src/"*.debian.tar.*  # dpkg-source copies these next to the tree
  echo "$v" >"$dir/.cadinterp-version"
  echo "fetch-wasm-sources: $src $v -> $dir"
done
