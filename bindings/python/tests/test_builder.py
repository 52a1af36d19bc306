"""cadinterp.build with hosts written in Python: the box host end to end against its closed
form, the sample store, infeasible points from host exceptions, malformed hosts and outputs,
progress, cancellation and Ctrl-C, and callbacks on the builder's worker threads."""
import os
import signal
import threading
import time

import numpy as np
import pytest

import cadinterp
from box_host import BoxHost, closed_form

COARSE = dict(geometry_tolerance=1e-2, field_tolerance=1e-1, max_samples=16)


def test_box_end_to_end(box_asset):
    path, report, host = box_asset
    assert report.output == str(path) and report.asset_bytes == path.stat().st_size
    assert report.host_evaluations > 0 and report.infeasible_points == 0
    assert report.samples > 4 and report.elements > 1  # the nonlinear depth needed refinement
    assert not report.budget_exhausted and report.max_error <= 1.0
    with cadinterp.Asset(path) as a:
        assert [(p.name, p.lower, p.upper, p.unit) for p in a.parameters] == list(host.parameters)
        assert [(f.name, f.location, f.unit) for f in a.fields] == [
            ("temperature", "vertex", "K"), ("pressure", "tet", "Pa")]
        assert [(r.name, r.kind, r.face_tags.tolist()) for r in a.regions] == [
            ("bottom", "fixed", [4]), ("top", "force", [5])]
        assert a.provenance.host == "python-box"
        X = np.random.default_rng(7).uniform(1.0, 2.0, (40, 2))
        for x, m in zip(X, a.eval_many(X, threads=2)):
            pos, temperature, pressure = closed_form(host.ref, x)
            diagonal = np.linalg.norm(pos.max(axis=0) - pos.min(axis=0))
            # The build's targets (geometry 1e-3 of the diagonal, fields 1e-3 of their range):
            # the grid is fixed, so vertex i is the same grid point in the asset and the closed
            # form, and the bound holds per vertex.
            assert np.abs(m.vertices - pos).max() <= 1e-3 * diagonal
            assert np.abs(m.fields["temperature"] - temperature).max() <= 1e-3 * np.ptp(temperature)
            assert np.abs(m.fields["pressure"] - pressure).max() <= 1e-5 * pressure
            w, h = x
            volume = a.eval_properties(x)["volume"]
            assert volume == pytest.approx(w * h * (0.5 + 0.25 * w * w), rel=3e-3)
            np.testing.assert_array_equal(m.tets, host.tets)


def test_store_resumes_and_refuses_another_identity(tmp_path):
    store = tmp_path / "box.store"
    first = cadinterp.build(BoxHost(), tmp_path / "a.cadi", store=store, **COARSE)
    again = cadinterp.build(BoxHost(), tmp_path / "b.cadi", store=store, **COARSE)
    assert first.host_evaluations > 0 and first.store_hits == 0
    assert again.host_evaluations == 0 and again.store_hits == first.host_evaluations
    assert (tmp_path / "a.cadi").read_bytes() == (tmp_path / "b.cadi").read_bytes()
    with pytest.raises(cadinterp.StoreMismatchError):
        cadinterp.build(BoxHost(fail_above=1.5), tmp_path / "c.cadi", store=store, **COARSE)


def test_calibration_points_are_asked_and_reported(tmp_path):
    plain = cadinterp.build(BoxHost(), tmp_path / "a.cadi", **COARSE)
    calibrated = cadinterp.build(BoxHost(), tmp_path / "b.cadi", calibration_points=40, **COARSE)
    assert plain.stages["calibrated_points"] == 0 and plain.stages["calibration"] == []
    assert plain.stages["calibration_floors"] == []
    assert calibrated.host_evaluations == plain.host_evaluations + 40
    assert calibrated.samples == plain.samples
    assert calibrated.stages["calibrated_points"] == 40
    factors = calibrated.stages["calibration"]
    assert len(factors) == 3 and all(f > 0 for f in factors)  # geometry, temperature, pressure
    floors = calibrated.stages["calibration_floors"]
    assert len(floors) == 3 and all(f >= 0 for f in floors)
    # One remedy per quantity: a raised floor leaves the factor at 1.
    assert all(f == 1 for f, add in zip(factors, floors) if add > 0)
    with pytest.raises(cadinterp.InvalidArgumentError):
        cadinterp.build(BoxHost(), tmp_path / "c.cadi", calibration_points=-1, **COARSE)


def test_host_exception_makes_an_infeasible_point(tmp_path):
    path = tmp_path / "corner.cadi"
    report = cadinterp.build(BoxHost(fail_above=1.7), path, **COARSE)
    assert report.infeasible_points > 0 and report.infeasible_elements > 0
    message, count = report.infeasible_reasons[0]
    assert "ValueError: no box beyond 1.7 (x = [" in message and count > 0
    with cadinterp.Asset(path) as a:
        assert a.infeasible_points
        for p in a.infeasible_points:
            assert min(p.x) > 1.7 and "ValueError: no box beyond 1.7 (x = [" in p.message
        with pytest.raises(cadinterp.InfeasibleError):
            a.eval([1.99, 1.99])
        a.eval([1.1, 1.1])  # the rest of the box is there


class Broken(BoxHost):
    """A box host whose regenerate returns what `mutate` makes of the good mesh."""

    def __init__(self, mutate):
        super().__init__()
        self.mutate = mutate

    def regenerate(self, x):
        return self.mutate(super().regenerate(x))


@pytest.mark.parametrize("mutate,message", [
    (lambda m: [m["vertices"]], "TypeError: regenerate must return a dict"),
    (lambda m: {**m, "vertices": np.full((27, 3), "a")}, "TypeError: regenerate's vertices"),
    (lambda m: {**m, "vertices": m["vertices"][:, :2]}, "ValueError: regenerate's vertices"),
    (lambda m: {**m, "tets": -m["tets"]}, "ValueError: regenerate's tets must lie in [0, 26]"),
    (lambda m: {**m, "triangles": m["triangles"] + 100}, "ValueError: regenerate's triangles"),
    (lambda m: {k: v for k, v in m.items() if k != "tets"}, "ValueError: regenerate returned no tets"),
    (lambda m: {**m, "triangle_tags": m["triangle_tags"][1:]}, "ValueError: regenerate returned 48"),
    # Inverted tets: the builder's own check of a mesh.
    (lambda m: {**m, "tets": m["tets"][:, [1, 0, 2, 3]]}, "regenerate: tet 0 is inverted"),
])
def test_malformed_meshes_are_infeasible(tmp_path, mutate, message):
    with pytest.raises(cadinterp.InfeasibleError) as e:
        cadinterp.build(Broken(mutate), tmp_path / "x.cadi", **COARSE)
    report = e.value.report
    assert report.infeasible_points == report.host_evaluations > 0
    assert message in report.infeasible_reasons[0][0], report.infeasible_reasons


class BadFields(BoxHost):
    def __init__(self, fields):
        super().__init__()
        self.fields = fields

    def simulate(self, x, mesh):
        return self.fields(mesh)


@pytest.mark.parametrize("fields,message", [
    (lambda m: dict(name="t", values=np.zeros(27)), "TypeError: simulate must return a list"),
    (lambda m: [dict(name="t", location="face", values=np.zeros(27))], "ValueError: field 't'"),
    (lambda m: [dict(name="t", values=np.zeros(27), colour=1)], "ValueError: simulate's field 0"),
    (lambda m: [dict(name="t", values=np.zeros((27, 2, 2)))], "ValueError: field 't'"),
    (lambda m: [dict(name="", values=np.zeros(27))], "ValueError: simulate's field 0"),
    # Too few rows: the builder's own check of a field.
    (lambda m: [dict(name="t", values=np.zeros(26))], "field 't' has 26 values, expected 27"),
])
def test_malformed_fields_are_infeasible(tmp_path, fields, message):
    with pytest.raises(cadinterp.InfeasibleError) as e:
        cadinterp.build(BadFields(fields), tmp_path / "x.cadi", **COARSE)
    assert message in e.value.report.infeasible_reasons[0][0], e.value.report


class Described(BoxHost):
    pass


@pytest.mark.parametrize("attrs,error,match", [
    (dict(name=None), TypeError, "name"),
    (dict(name=""), TypeError, "name"),
    (dict(identity=3), TypeError, "identity"),
    (dict(parameters=[]), ValueError, "1 to 8 parameters"),
    (dict(parameters=[("w", 2.0, 1.0)]), ValueError, "lower < upper"),
    (dict(parameters=[("w", 0.0)]), ValueError, "parameter 0"),
    (dict(parameters=["width"]), ValueError, "parameter 0"),
    (dict(parameters=[("w", 0.0, float("inf"))]), ValueError, "finite"),
    (dict(regenerate=None), TypeError, "regenerate"),
    (dict(simulate=42), TypeError, "simulate"),
])
def test_malformed_hosts(tmp_path, attrs, error, match):
    host = type("H", (Described,), attrs)()
    with pytest.raises(error, match=match):
        cadinterp.build(host, tmp_path / "x.cadi")


def test_duck_typed_host_without_optional_methods(tmp_path):
    box = BoxHost()

    class Minimal:  # no base class, no references, no simulate
        name = "minimal"
        parameters = [("width", 1.0, 2.0), ("height", 1.0, 2.0)]

        def regenerate(self, x):
            return box.regenerate(x)

    report = cadinterp.build(Minimal(), tmp_path / "m.cadi", **COARSE)
    with cadinterp.Asset(tmp_path / "m.cadi") as a:
        assert a.fields == [] and a.regions == [] and report.samples > 0
        assert a.parameters[0].unit == ""


def test_bad_output_and_options(tmp_path):
    calls = []

    class Counting(BoxHost):
        def regenerate(self, x):
            calls.append(x)
            return super().regenerate(x)

    with pytest.raises(cadinterp.IoError):
        cadinterp.build(Counting(), tmp_path / "no" / "such" / "dir.cadi")
    assert calls == []  # refused before any host call
    with pytest.raises(cadinterp.InvalidArgumentError):
        cadinterp.build(Counting(), tmp_path / "x.cadi", degree=2)
    with pytest.raises(cadinterp.InvalidArgumentError):
        cadinterp.build(Counting(), tmp_path / "x.cadi", geometry_tolerance=-1.0)
    with pytest.raises(TypeError, match="progress"):
        cadinterp.build(Counting(), tmp_path / "x.cadi", progress=3)
    with pytest.raises(TypeError):
        cadinterp.build(Counting(), tmp_path / "x.cadi", no_such_option=1)


def test_progress_and_cancel(tmp_path):
    seen = []
    cadinterp.build(BoxHost(), tmp_path / "a.cadi", progress=seen.append, **COARSE)
    assert seen and set(seen[0]) == {"samples_done", "samples_queued", "elements", "seconds",
                                     "eta_seconds"}
    assert seen[-1]["samples_done"] >= seen[0]["samples_done"]
    with pytest.raises(cadinterp.CancelledError) as e:
        cadinterp.build(BoxHost(), tmp_path / "b.cadi", progress=lambda p: p["samples_done"] >= 3)
    assert e.value.report.host_evaluations >= 3
    assert not (tmp_path / "b.cadi").exists()

    def interrupt(p):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        cadinterp.build(BoxHost(), tmp_path / "c.cadi", progress=interrupt)


class Slow(BoxHost):
    thread_safe = False

    def regenerate(self, x):
        time.sleep(0.02)
        return super().regenerate(x)


def test_ctrl_c_cancels_a_build(tmp_path):
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        cadinterp.build(Slow(), tmp_path / "slow.cadi", geometry_tolerance=1e-4,
                        field_tolerance=1e-4, max_samples=10000)
    assert time.monotonic() - start < 5.0
    assert not (tmp_path / "slow.cadi").exists()


def test_callbacks_run_on_worker_threads_with_the_gil(tmp_path):
    threads = set()
    ticks = []
    stop = threading.Event()

    class Recording(BoxHost):
        def regenerate(self, x):
            threads.add(threading.get_ident())
            return super().regenerate(x)

    def ticker():  # another Python thread keeps running during the build
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    try:
        report = cadinterp.build(Recording(), tmp_path / "t.cadi", threads=2,
                                 geometry_tolerance=1e-3, field_tolerance=1e-2)
    finally:
        stop.set()
        t.join()
    assert report.host_evaluations > 0 and threads - {threading.main_thread().ident}
    assert len(ticks) > 0


def test_calling_thread_runs_the_host_only_on_this_thread(tmp_path):
    threads = set()

    class Recording(BoxHost):
        def regenerate(self, x):
            threads.add(threading.get_ident())
            return super().regenerate(x)

    options = dict(geometry_tolerance=1e-3, field_tolerance=1e-2)
    report = cadinterp.build(Recording(), tmp_path / "c.cadi", threads=4, calling_thread=True,
                             **options)
    assert report.host_evaluations > 0
    assert threads == {threading.get_ident()}
    cadinterp.build(BoxHost(), tmp_path / "w.cadi", threads=2, **options)
    assert (tmp_path / "c.cadi").read_bytes() == (tmp_path / "w.cadi").read_bytes()


class OutputsHost(BoxHost):
    """The box with two exact per-sample outputs: its volume w h (0.5 + 0.25 w^2) and w + h."""
    identity = BoxHost.identity + ", outputs volume and w_plus_h"

    def regenerate(self, x):
        mesh = super().regenerate(x)
        w, h = x
        mesh["outputs"] = {"volume": (w * h * (0.5 + 0.25 * w * w), "mm^3"), "w_plus_h": w + h}
        return mesh


def test_outputs_are_interpolated_with_exact_gradients(tmp_path):
    report = cadinterp.build(OutputsHost(), tmp_path / "o.cadi", geometry_tolerance=1e-3,
                             field_tolerance=1e-3, threads=2)
    assert report.infeasible_points == 0
    with cadinterp.Asset(tmp_path / "o.cadi") as a:
        assert a.outputs == [cadinterp.Output("volume", "mm^3"), cadinterp.Output("w_plus_h", "")]
        rng = np.random.default_rng(7)
        for x in rng.uniform(1.0, 2.0, size=(20, 2)):
            w, h = x
            values = a.eval_outputs(x)
            # w + h is linear: every basis reproduces it; the volume is held to field_tolerance.
            assert values["w_plus_h"] == pytest.approx(w + h, abs=1e-12)
            exact = w * h * (0.5 + 0.25 * w * w)
            assert values["volume"] == pytest.approx(exact, rel=5e-3)
            only, grads = a.eval_outputs(x, "volume", grad=True)
            assert list(only) == ["volume"] and only["volume"] == values["volume"]
            # The gradient is the interpolant's own: central differences of eval_outputs agree
            # away from element boundaries (a linear asset's kinks), checked in a small step.
            for d in range(2):
                step = np.zeros(2)
                step[d] = 1e-7
                fd = (a.eval_outputs(x + step, "volume")["volume"] -
                      a.eval_outputs(x - step, "volume")["volume"]) / 2e-7
                assert grads["volume"][d] == pytest.approx(fd, rel=1e-4, abs=1e-6)
            _, g = a.eval_outputs(x, ["w_plus_h"], grad=True)
            np.testing.assert_allclose(g["w_plus_h"], [1.0, 1.0], atol=1e-9)
        with pytest.raises(cadinterp.NotFoundError, match="no output named 'mass'"):
            a.eval_outputs([1.5, 1.5], "mass")
        with pytest.raises(TypeError):
            a.eval_outputs([1.5, 1.5], [0])
    with cadinterp.Asset(tmp_path / "o.cadi") as a:
        assert a.eval_outputs([1.5, 1.5], []) == {}


def test_a_non_finite_output_makes_the_point_infeasible(tmp_path):
    class Bad(OutputsHost):
        identity = OutputsHost.identity + ", nan"

        def regenerate(self, x):
            mesh = super().regenerate(x)
            if x[0] > 1.5:
                mesh["outputs"]["volume"] = float("nan")
            return mesh

    report = cadinterp.build(Bad(), tmp_path / "b.cadi", **COARSE)
    assert report.infeasible_points > 0
    assert any("not finite" in message for message, _ in report.infeasible_reasons)
