#!/usr/bin/env bash
# The main job: installs what is missing, builds the release preset, precomputes the analytic
# bracket model (4 parameters: length, height, thickness, bend angle; temperature and von Mises
# fields) into an asset, then prints what is in it and evaluates it at two designs, writing the
# meshes as VTU (ParaView) and glTF (any viewer) into build/demo/.
#   scripts/demo.sh [extra `cadinterp build` options, e.g. --geometry-tol 5e-4 --threads 2]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)" --target cadinterp_cli
cli=./build/release/src/tools/cadinterp
out=build/demo
mkdir -p "$out"
# The store makes the build resumable: run the script again after Ctrl-C and it continues.
"$cli" build --host analytic --model bracket --store "$out/bracket.store" \
  -o "$out/bracket.cadi" "$@"
"$cli" inspect "$out/bracket.cadi"
"$cli" eval "$out/bracket.cadi" 50 40 5 90 --fields temperature,von_mises \
  --vtu "$out/bracket_50_40_5_90.vtu" --gltf "$out/bracket_50_40_5_90.glb"
"$cli" eval "$out/bracket.cadi" 75 55 7.5 120 --grad \
  --vtu "$out/bracket_75_55_7.5_120.vtu"
echo "meshes written to $out/"
