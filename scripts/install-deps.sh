#!/usr/bin/env bash
# Installs every Debian package the build and the tests need. Idempotent: packages already
# present are skipped and apt is not touched when nothing is missing. Uses sudo only when not
# running as root.
set -euo pipefail

PACKAGES=(
  build-essential   # gcc, g++, make
  cmake
  ninja-build
  pkg-config
  googletest        # GoogleTest + GoogleMock sources
  libgtest-dev
  libgmock-dev
  libbenchmark-dev  # Google Benchmark
  libeigen3-dev
  clang-format
  flatbuffers-compiler  # flatc: the asset index schema
  libflatbuffers-dev
  libzstd-dev           # codecs
  libsqlite3-dev        # the builder's sample store
  libmeshoptimizer-dev
  libdraco-dev
  libxxhash-dev         # blob checksums
  binutils              # nm: the export check of libcadinterp
  clang                 # libFuzzer target (scripts/fuzz.sh)
  libclang-rt-14-dev
  libocct-foundation-dev            # the OpenCASCADE example host (B-rep kernel)
  libocct-modeling-data-dev
  libocct-modeling-algorithms-dev
  libocct-visualization-dev         # ships NCollection_AliasedArray.hxx, which the foundation's
                                    # Poly_ArrayOfNodes.hxx includes (Debian 12's split of OCCT)
  libtet1.5-dev                     # TetGen: tetrahedralization in the OpenCASCADE host
  libsuitesparse-dev                # CHOLMOD: the FEM physics' direct solver
  libcpp-httplib-dev                # `cadinterp explore`'s embedded HTTP server
  emscripten                        # the WebAssembly runtime (bindings/wasm); its codec sources
                                    # come from Debian source packages (fetch-codec-sources.sh)
  chromium                          # the explorer's end-to-end tests (headless)
  # The Python package (bindings/python), built and tested with Debian's /usr/bin/python3.
  python3-dev                       # Python.h for the extension module
  pybind11-dev
  python3-numpy
  python3-pytest                    # its tests (ctest -L python)
  python3-matplotlib                # examples/sweep.py and its test
  python3-scipy                     # cadinterp.Problem's scipy adapters, tested (python_optimize)
  # The frozen runtime ABI (abi/): abidw and abidiff run by the abi_check ctests; without them
  # the checks skip, so CI must have them.
  abigail-tools
  # Shape optimization (src/optimize, `cadinterp optimize`): Ipopt, found through pkg-config.
  coinor-libipopt-dev
  # Cross builds of the runtime (scripts/test-cross.sh, docs/portability.md): Windows through
  # MinGW-w64, run under Wine (codec libraries from source, fetch-codec-sources.sh); arm64 against
  # Debian's multiarch :arm64 libraries, run under qemu-user (architecture added below).
  g++-mingw-w64-x86-64
  wine
  wine64
  qemu-user
  g++-aarch64-linux-gnu
  libzstd-dev:arm64
  libmeshoptimizer-dev:arm64
  libdraco-dev:arm64
  libflatbuffers-dev:arm64
  libxxhash-dev:arm64
  libgtest-dev:arm64
  libgmock-dev:arm64
  # The FreeCAD example host (examples/hosts/freecad, Python): the CAD kernel, the mesher, the
  # FEM solver, and scipy for its accuracy measures.
  freecad-python3
  python3-gmsh
  calculix-ccx
  python3-scipy
  # Distributed builds, `mpirun -np N cadinterp build --mpi` (src/tools/mpi_driver.h): Open MPI's
  # headers and libraries, and mpirun for the tests labelled 'mpi'.
  libopenmpi-dev
  openmpi-bin
)

# Node.js: the WebAssembly tests and the explorer (vite 7, playwright-core) need Node >= 20.19 and
# npm. Debian 12's own nodejs is 18, so it is not installed from here: say so plainly instead.
node_ok=$(node -e 'const [a,b]=process.versions.node.split(".").map(Number);
  console.log(a>20||(a===20&&b>=19)?1:0)' 2>/dev/null || echo 0)
if [ "$node_ok" != 1 ] || ! command -v npm >/dev/null; then
  echo "install-deps: Node.js >= 20.19 with npm is required (found: $(node --version 2>/dev/null || echo none))" >&2
  exit 1
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
# The :arm64 packages need the architecture known to dpkg (once; the update below reads its
# indexes).
if printf '%s\n' "${missing[@]}" | grep -q ':arm64$' &&
   ! dpkg --print-foreign-architectures | grep -qx arm64; then
  $SUDO dpkg --add-architecture arm64
fi
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"

