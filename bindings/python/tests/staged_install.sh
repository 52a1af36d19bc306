#!/usr/bin/env bash
# `import cadinterp` from a fresh environment against a staged install (DESTDIR), not the build
# tree: the package lands in the site-packages Debian's python3 reads for the prefix, and its
# module finds libcadinterp, libcadinterp_builder and (in builds with the optimizer)
# libcadinterp_optimize through its $ORIGIN-relative RUNPATH.
#   staged_install.sh BUILD_DIR PREFIX SITE_DIR LIBDIR PYTHON ASSET
# Exits 77 (ctest: skipped, with the reason printed) when `cmake --install` installs no
# libcadinterp: the libraries' install rules belong to the project's install step.
set -euo pipefail
build=$1 prefix=$2 site=$3 libdir=$4 python=$5 asset=$6
stage=$build/bindings/python/staged
rm -rf "$stage"
DESTDIR=$stage cmake --install "$build" >"$build/bindings/python/staged-install.log"
pkg=$stage$prefix/$site
module=$(ls "$pkg"/cadinterp/_cadinterp*.so)
if ! ls "$stage$prefix/$libdir"/libcadinterp.so.* >/dev/null 2>&1; then
  echo "SKIP: cmake --install put no libcadinterp in $prefix/$libdir (no install rule for it)"
  exit 77
fi
runpath=$(readelf -d "$module" | sed -n 's/.*R\(UN\)\?PATH.*\[\(.*\)\]/\2/p')
echo "installed module: ${module#"$stage"} (RUNPATH $runpath)"
case $runpath in
  *"$build"*) echo "FAIL: the installed module's RUNPATH names the build tree"; exit 1 ;;
  '$ORIGIN/'*) ;;
  *) echo "FAIL: the installed module's RUNPATH is not \$ORIGIN-relative"; exit 1 ;;
esac
# A fresh environment: no LD_LIBRARY_PATH, only the staged site-packages on PYTHONPATH, and -P:
# no current folder on sys.path.
cd "$stage"  # not a folder holding the build tree's package
env -i PATH=/usr/bin:/bin PYTHONDONTWRITEBYTECODE=1 PYTHONPATH="$pkg" "$python" -P - "$pkg" "$asset" <<'PY'
import sys
import cadinterp
pkg, asset = sys.argv[1], sys.argv[2]
assert cadinterp.__file__.startswith(pkg), cadinterp.__file__
with cadinterp.Asset(asset) as a:
    m = a.eval(a.bounds.mean(axis=1))
    if cadinterp._cadinterp.has_optimizer:  # loads libcadinterp_optimize (and Ipopt)
        r = cadinterp.Problem(a).minimize("volume").solve(max_iterations=3)
        print(f"Problem.solve: {r.status}, objective {r.objective:.6g} at {r.x}")
print(f"import cadinterp {cadinterp.__version__} from {cadinterp.__file__}: {m}")
PY
rm -rf "$stage"  # the whole project's install: no need to keep it
