#!/usr/bin/env bash
# Fetches the C/C++ sources of the codec libraries the runtime decodes blobs with (zstd,
# meshoptimizer, Draco) for the builds Debian has no libraries for (WebAssembly, Windows through
# MinGW-w64): the Debian *source* packages of exactly the installed -dev versions are downloaded
# and unpacked into a cache outside git, so that every build decodes exactly what the native
# encoder writes. Also copies the header-only libraries (FlatBuffers, xxHash) into
# CACHE_DIR/include, so that a cross compiler never sees the host's /usr/include. Idempotent: a
# second run does nothing (no network).
#
# Usage: scripts/fetch-codec-sources.sh [CACHE_DIR]     (default: build/codec-sources)
# Prints nothing but progress; the unpacked trees are CACHE_DIR/src/{zstd,meshoptimizer,draco}.
# Used by scripts/build-wasm.sh and scripts/test-cross.sh (cmake/codec_sources.cmake compiles
# the decoders).
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
cache="${1:-$root/build/codec-sources}"
mkdir -p "$cache/src" "$cache/download" "$cache/include"

# Private copies of the header-only libraries, refreshed when the installed ones change.
if [ ! -f "$cache/include/flatbuffers/flatbuffers.h" ] ||
   [ /usr/include/flatbuffers/flatbuffers.h -nt "$cache/include/flatbuffers/flatbuffers.h" ]; then
  rm -rf "$cache/include/flatbuffers"
  cp -r /usr/include/flatbuffers "$cache/include/flatbuffers"
fi
if [ ! -f "$cache/include/xxhash.h" ] || [ /usr/include/xxhash.h -nt "$cache/include/xxhash.h" ]; then
  cp /usr/include/xxhash.h "$cache/include/xxhash.h"
fi

# Source package -> installed binary package whose version must match (the native build links
# the binary one; the WASM build must decode exactly what the native encoder writes).
declare -A binary_of=([libzstd]=libzstd-dev [meshoptimizer]=libmeshoptimizer-dev [draco]=libdraco-dev)
declare -A dir_of=([libzstd]=zstd [meshoptimizer]=meshoptimizer [draco]=draco)

# The native architecture's package: with multiarch (:arm64 for scripts/test-cross.sh) installed,
# an unqualified query prints one version per architecture.
version_of() {
  dpkg-query -W -f='${Version}' "$1:$(dpkg --print-architecture)" 2>/dev/null || true
}

need_fetch=0
for src in libzstd meshoptimizer draco; do
  v="$(version_of "${binary_of[$src]}")"
  if [ -z "$v" ]; then
    echo "fetch-codec-sources: ${binary_of[$src]} is not installed (scripts/install-deps.sh)" >&2
    exit 1
  fi
  stamp="$cache/src/${dir_of[$src]}/.cadinterp-version"
  if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$v" ]; then need_fetch=1; fi
done
if [ "$need_fetch" = 0 ]; then
  echo "fetch-codec-sources: sources up to date in $cache/src"
  exit 0
fi

# A deb-src entry mirroring the binary one (same URIs, suites, components and key).
src_list=/etc/apt/sources.list.d/debian-src.sources
if ! grep -rqs '^Types:.*deb-src' /etc/apt/sources.list.d/ /etc/apt/sources.list 2>/dev/null; then
  if [ ! -f /etc/apt/sources.list.d/debian.sources ]; then
    echo "fetch-codec-sources: no /etc/apt/sources.list.d/debian.sources to derive a deb-src entry from" >&2
    exit 1
  fi
  sudo_cmd=()
  [ "$(id -u)" = 0 ] || sudo_cmd=(sudo)
  echo "fetch-codec-sources: adding $src_list"
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
    echo "fetch-codec-sources: apt-get source --download-only $src=$v"
    got="$v"
    if ! apt-get source -qq --download-only "$src=$v"; then
      # A mirror may list a security update's source package without serving its files (seen
      # for libzstd 1.5.4+dfsg2-5+deb12u1). Another Debian revision of the same upstream release
      # decodes the same streams, so the newest one that downloads is taken, and said.
      got=""
      for alt in $(apt-cache showsrc "$src" | sed -n 's/^Version: //p' | sort -rV | uniq); do
        [ "$alt" != "$v" ] && [ "${alt%-*}" = "${v%-*}" ] || continue
        echo "fetch-codec-sources: $src=$v cannot be downloaded; taking $src=$alt, the same upstream release"
        if apt-get source -qq --download-only "$src=$alt"; then
          got="$alt"
          break
        fi
      done
      if [ -z "$got" ]; then
        echo "fetch-codec-sources: no source package of $src ${v%-*} can be downloaded" >&2
        exit 1
      fi
    fi
    dsc="${src}_${got#*:}.dsc"
  fi
  rm -rf "$dir" "$dir.tmp"
  # No signature check needed beyond apt's: the files were verified against the signed index.
  dpkg-source --no-check -x "$dsc" "$dir.tmp" >/dev/null
  mv "$dir.tmp" "$dir"
  rm -f "$cache/src/"*.orig.tar.* "$cache/src/"*.debian.tar.*  # dpkg-source copies these next to the tree
  echo "$v" >"$dir/.cadinterp-version"
  echo "fetch-codec-sources: $src $v -> $dir"
done
