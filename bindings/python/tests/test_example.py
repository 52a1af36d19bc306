"""examples/sweep.py run as a user runs it (a subprocess of this interpreter), on small assets
built by the box host: the PNG is written and the printed sweep matches the asset."""
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import cadinterp
from box_host import BoxHost

SWEEP = pathlib.Path(__file__).resolve().parents[1] / "examples" / "sweep.py"


def run_sweep(*args):
    run = subprocess.run([sys.executable, str(SWEEP), *map(str, args)], capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    return run.stdout


def table(stdout):
    rows = [line.split() for line in stdout.splitlines()[1:] if not line.startswith("sweep:")]
    return np.array(rows, dtype=float)


def is_png(path):
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000


def test_sweep_of_the_box(box_asset, tmp_path):
    path, _, _ = box_asset
    png = tmp_path / "box.png"
    out = run_sweep(path, "--parameter", "width", "--at", "height=1.5", "--points", "9",
                    "-o", png)
    assert is_png(png) and "9 of 9 points feasible" in out
    rows = table(out)
    np.testing.assert_allclose(rows[:, 0], np.linspace(1, 2, 9))
    with cadinterp.Asset(path) as a:
        for w, mass, peak, error in rows:
            x = [w, 1.5]
            assert mass == pytest.approx(a.eval_properties(x)["mass"], rel=1e-5)
            assert peak == pytest.approx(a.eval(x, "temperature").fields["temperature"].max(),
                                         rel=1e-5)
            assert error == pytest.approx(a.error_estimate(x), rel=1e-2)


def test_sweep_leaves_infeasible_points_out(tmp_path):
    path = tmp_path / "corner.cadi"
    cadinterp.build(BoxHost(fail_above=1.7), path, geometry_tolerance=1e-2, field_tolerance=0.1)
    png = tmp_path / "corner.png"
    out = run_sweep(path, "--at", "height=1.9", "--points", "11", "--field", "pressure",
                    "-o", png)
    rows = table(out)
    feasible = np.isfinite(rows[:, 1])
    assert is_png(png) and 0 < feasible.sum() < len(rows)
    assert f"{feasible.sum()} of 11 points feasible" in out
    # The host fails beyond 1.7; the asset refuses whole elements around that corner.
    assert (rows[~feasible, 0] > 1.5).all() and feasible[rows[:, 0] < 1.5].all()


def test_sweep_refuses_unknown_names(box_asset, tmp_path):
    path, _, _ = box_asset
    for args in (["--parameter", "depth"], ["--field", "stress"], ["--at", "depth=1"]):
        run = subprocess.run([sys.executable, str(SWEEP), str(path), *args, "-o",
                              str(tmp_path / "x.png")], capture_output=True, text=True)
        assert run.returncode != 0 and "no " in run.stderr and not (tmp_path / "x.png").exists()


CALIBRATE = pathlib.Path(__file__).resolve().parents[1] / "examples" / "calibrate.py"


def run_calibrate(*args):
    return subprocess.run([sys.executable, str(CALIBRATE), *map(str, args)], capture_output=True,
                          text=True)


def test_calibrate_recomputes_the_estimates_against_the_tables_errors(box_asset, tmp_path):
    path, _, _ = box_asset
    rng = np.random.default_rng(5)
    with cadinterp.Asset(path) as a:
        names = [q.name for q in a.parameters]
        lo, hi = np.array(a.bounds).T
        X = lo + (hi - lo) * rng.random((10, len(names)))
        est = [a.error_estimates(x) for x in X]
    quantities = list(est[0])
    # Errors at half the estimate at 8 points and twice it at 2: bounded 80 %, ratios
    # 0.5 (x2) and 2 (x8), so median (the 6th of 10) 2 and p10 (the 2nd) 0.5.
    factor = [2.0] * 8 + [0.5] * 2
    table = tmp_path / "points.tsv"
    with open(table, "w") as f:
        f.write("\t".join(names[::-1] + [f"{q}_{c}" for q in quantities
                                         for c in ("estimate", "error")]) + "\n")
        for i, x in enumerate(X):
            cells = [repr(v) for v in x[::-1]]  # columns by name, not by position
            for j, q in enumerate(quantities):
                e = est[i][q]
                stale = 2 * e if (i, j) == (3, 0) else e  # one estimate of another runtime
                cells += [repr(stale), repr(e / factor[i])]
            f.write("\t".join(cells) + "\n")
    run = run_calibrate(path, table)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0] == "10 points, 0 refused by the asset"
    for q in quantities:
        row = next(line.split() for line in lines if line.split()[:1] == [q])
        if all(e[q] > 0 for e in est):
            assert row[1:] == ["10", "80%", "2.00", "0.50"], row
        else:  # a quantity the asset reproduces: errors 0, bounded, no ratio
            assert all(e[q] == 0 for e in est) and row[1:] == ["10", "100%", "nan", "nan"], row
    assert all(e["geometry"] > 0 for e in est)
    assert lines[-1] == f"estimates that differ from the table's: 1 of {10 * len(quantities)}"


def test_calibrate_refuses_a_table_of_another_asset(box_asset, tmp_path):
    path, _, _ = box_asset
    table = tmp_path / "other.tsv"
    table.write_text("depth\tgeometry_estimate\tgeometry_error\n1.0\t0.1\t0.05\n")
    run = run_calibrate(path, table)
    assert run.returncode != 0 and "not a points table of this asset" in run.stderr
    table.write_text("")
    run = run_calibrate(path, table)
    assert run.returncode != 0 and "no points" in run.stderr
