#!/usr/bin/env bash
# The main job: installs what is missing, builds the release preset, and runs the core demo
# (accuracy and continuity figures of the interpolation core on analytic functions).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)" --target cadinterp-core-demo
exec ./build/release/src/tools/cadinterp-core-demo "$@"
