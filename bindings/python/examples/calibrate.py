#!/usr/bin/python3
"""Calibrates an asset's error estimates against true errors measured earlier, without calling the
host again: the estimates are recomputed by the cadinterp runtime in use (Asset.error_estimates)
at the points of a table of true errors, and compared with them.

    PYTHONPATH=build/release/bindings/python /usr/bin/python3 \\
        bindings/python/examples/calibrate.py ASSET POINTS.tsv

POINTS.tsv is the per-point table `cadinterp-occt-results` writes next to the asset
(DIR/occt_results_MODEL[_cubic]_points.tsv): a header line, then one line per point, its
parameters by name, then per quantity `<quantity>_estimate` and `<quantity>_error` (the
estimate the runtime of that run gave, and the true error). Printed per quantity, as that tool
prints them: the points compared, the share where the estimate bounds the error, and the median
and 10th percentile of estimate / error over the points whose error is above 1e-12. Then how
many estimates differ from the table's: a runtime whose estimate model changed is checked on
the same points and truths. Points the asset refuses (infeasible elements) are counted and left
out.
"""
import argparse
import csv
import sys

import numpy as np

import cadinterp


def read_points(path, parameter_names):
    """(X, quantities, estimates, errors): X by the asset's parameter order; the two (points x
    quantities) arrays, NaN where the table has no estimate (-1) or no error."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f, delimiter="\t"))
    if len(rows) < 2:
        sys.exit(f"calibrate: {path}: no points")
    header = rows[0]
    quantities = [h[:-len("_estimate")] for h in header if h.endswith("_estimate")]
    missing = [n for n in parameter_names if n not in header]
    if not quantities or missing:
        sys.exit(f"calibrate: {path}: not a points table of this asset "
                 f"(no estimate columns, or no column for {', '.join(missing)})")
    column = {h: i for i, h in enumerate(header)}
    try:
        values = np.array([[float(v) for v in r] for r in rows[1:] if r], dtype=float)
    except ValueError as e:
        sys.exit(f"calibrate: {path}: {e}")
    if values.shape[1] != len(header):
        sys.exit(f"calibrate: {path}: rows do not have the header's {len(header)} columns")
    X = values[:, [column[n] for n in parameter_names]]
    est = values[:, [column[q + "_estimate"] for q in quantities]]
    err = values[:, [column[q + "_error"] for q in quantities]]
    est[est < 0] = np.nan
    return X, quantities, est, err


def calibration(estimates, errors):
    """(points, bounded share, median, p10) of the pairs where both are known, the median and
    p10 as the builder's accuracy report takes them (sorted ratios at n / 2 and n / 10)."""
    known = np.isfinite(estimates) & np.isfinite(errors)
    e, t = estimates[known], errors[known]
    bounded = float(np.mean(e >= t)) if len(e) else float("nan")
    ratios = np.sort(e[t > 1e-12] / t[t > 1e-12])
    if not len(ratios):
        return len(e), bounded, float("nan"), float("nan")
    return len(e), bounded, float(ratios[len(ratios) // 2]), float(ratios[len(ratios) // 10])


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("asset")
    p.add_argument("points", help="the per-point table of true errors (tab-separated)")
    a = p.parse_args(argv)
    with cadinterp.Asset(a.asset) as asset:
        names = [q.name for q in asset.parameters]
        X, quantities, table_est, err = read_points(a.points, names)
        est = np.full_like(table_est, np.nan)
        refused = 0
        for i, x in enumerate(X):
            try:
                now = asset.error_estimates(x)
            except (cadinterp.InfeasibleError, cadinterp.OutsideDomainError):
                refused += 1
                continue
            for j, q in enumerate(quantities):
                est[i, j] = now.get(q, np.nan)
    print(f"{len(X)} points, {refused} refused by the asset")
    print(f"{'quantity':<14}{'points':>7}{'bounded':>9}{'median':>8}{'p10':>7}")
    for j, q in enumerate(quantities):
        n, bounded, median, p10 = calibration(est[:, j], err[:, j])
        print(f"{q:<14}{n:>7}{100 * bounded:>8.0f}%{median:>8.2f}{p10:>7.2f}")
    both = np.isfinite(est) & np.isfinite(table_est)
    differ = int(np.sum(np.abs(est[both] - table_est[both]) > 1e-5 * np.abs(table_est[both])))
    print(f"estimates that differ from the table's: {differ} of {int(both.sum())}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
