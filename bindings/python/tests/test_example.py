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
