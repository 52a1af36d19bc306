#!/usr/bin/python3
"""Builds the FreeCAD bracket into an asset and measures it against FreeCAD (README.md,
"Results"): the build's figures, `cadinterp inspect`, and the geometry and field errors of the
asset at random points against the host's own regeneration and CalculiX run there.

    PYTHONPATH=<build>/bindings/python /usr/bin/python3 examples/hosts/freecad/results.py \
        [--out DIR] [--mesh-size 2.5] [--max-samples 64] [--max-depth 4] [--points 20]
"""
import argparse
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import accuracy  # noqa: E402
import bracket_model  # noqa: E402
import cadinterp  # noqa: E402
import freecad_host  # noqa: E402

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="freecad-results", help="directory of the asset and store")
    p.add_argument("--mesh-size", type=float, default=2.5)
    p.add_argument("--levels", type=int, default=1)
    p.add_argument("--max-samples", type=int, default=64)
    p.add_argument("--max-depth", type=int, default=4)
    p.add_argument("--geometry-tolerance", type=float, default=1e-3)
    p.add_argument("--field-tolerance", type=float, default=5e-2)
    p.add_argument("--points", type=int, default=20)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--cli", default=os.path.join(REPO, "build/release/src/tools/cadinterp"),
                   help="the cadinterp tool, for `inspect` (skipped when absent)")
    return p.parse_args()


def build(args, host, asset_path):
    t = time.time()
    report = cadinterp.build(host, asset_path, store=os.path.join(args.out, "bracket.sqlite"),
                             geometry_tolerance=args.geometry_tolerance,
                             field_tolerance=args.field_tolerance, max_samples=args.max_samples,
                             max_depth=args.max_depth)
    print("build: %.0f s wall (%.0f s in the host over %d evaluations, %d from the store)"
          % (time.time() - t, report.host_seconds, report.host_evaluations, report.store_hits))
    print("  samples %d, elements %d (%d refused), infeasible points %d, max error %.3g x "
          "tolerance, budget exhausted %s, %d bytes"
          % (report.samples, report.elements, report.infeasible_elements,
             report.infeasible_points, report.max_error, report.budget_exhausted,
             report.asset_bytes))
    for message, count in report.infeasible_reasons:
        print("  infeasible (%d): %s" % (count, message))
    return report


def measure(args, host, asset):
    """Per point: (x, geometry error, von Mises errors, displacement errors, estimate, tets)
    or (x, None...) for a point the asset refuses although FreeCAD regenerates it."""
    rng = np.random.default_rng(args.seed)
    lo = np.array([p[1] for p in bracket_model.PARAMETERS])
    hi = np.array([p[2] for p in bracket_model.PARAMETERS])
    rows, lost, skipped = [], [], 0
    while len(rows) + len(lost) < args.points:
        x = rng.uniform(lo, hi)
        try:
            true = host.regenerate(x)
        except bracket_model.InfeasibleError:
            skipped += 1  # FreeCAD has no model here either: not an error of the asset
            continue
        try:
            m = asset.eval(x)
        except cadinterp.InfeasibleError as e:
            lost.append((x, str(e)))
            continue
        fields = {f["name"]: f["values"] for f in host.simulate(x, true)}
        interp = dict(vertices=m.vertices, triangles=m.triangles)
        rows.append((x, accuracy.relative_hausdorff(interp, true),
                     accuracy.field_errors(m.vertices, m.fields["von_mises"], true,
                                           fields["von_mises"]),
                     accuracy.field_errors(m.vertices, m.fields["displacement"], true,
                                           fields["displacement"]),
                     asset.error_estimate(x), len(m.tets)))
    return rows, lost, skipped


def main():
    args = parse_args()
    os.makedirs(args.out, exist_ok=True)
    asset_path = os.path.join(args.out, "bracket.cadi")
    host = freecad_host.BracketHost(mesh_size=args.mesh_size, levels=args.levels)
    print("host identity:", host.identity)
    report = build(args, host, asset_path)
    if os.path.exists(args.cli):
        print(subprocess.run([args.cli, "inspect", asset_path], capture_output=True,
                             text=True).stdout)
    asset = cadinterp.Asset(asset_path)
    rows, lost, skipped = measure(args, host, asset)
    print("%-16s %10s %10s %10s %10s %6s" % ("x", "geometry", "vm max", "u max", "estimate", "tets"))
    for x, g, vm, u, est, tets in rows:
        print("%-16s %10.2e %10.3f %10.4f %10.2e %6d"
              % ("(%.2f, %.2f)" % tuple(x), g, vm.max(), u.max(), est, tets))
    for x, why in lost:
        print("(%.2f, %.2f) lost: %s" % (tuple(x) + (why,)))
    geo = np.array([r[1] for r in rows])
    vm = np.concatenate([r[2] for r in rows])
    u = np.concatenate([r[3] for r in rows])
    tets = np.mean([r[5] for r in rows])
    print("\n%d points (%d more drawn where FreeCAD itself has no model)" % (len(rows) + len(lost), skipped))
    print("| K | samples | elements (refused) | mean tets | host s / evaluation | geometry max / 99 % "
          "| von Mises max / 99 % | displacement max / 99 % | points lost |")
    print("|---|---|---|---|---|---|---|---|---|")
    print("| %d | %d | %d (%d) | %.0f | %.1f | %.4f / %.4f | %.3f / %.3f | %.4f / %.4f | %d of %d |"
          % (len(bracket_model.PARAMETERS), report.samples, report.elements,
             report.infeasible_elements, tets,
             report.host_seconds / max(1, report.host_evaluations), geo.max(),
             np.percentile(geo, 99), vm.max(), np.percentile(vm, 99), u.max(),
             np.percentile(u, 99), len(lost), len(rows) + len(lost)))


if __name__ == "__main__":
    main()
