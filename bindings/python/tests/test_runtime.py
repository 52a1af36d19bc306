"""The runtime API on the conformance assets: description, eval/grad/vjp/properties and their
agreement, eval_many, the lifetime rule of the returned views, and threads."""
import gc
import pathlib
import threading

import numpy as np
import pytest

import cadinterp


@pytest.fixture
def cubic(cases):
    with cadinterp.Asset(cases / "valid" / "k2_cubic" / "asset.cadi") as a:
        yield a


def points(asset, n, seed=0):
    lo, hi = asset.bounds[:, 0], asset.bounds[:, 1]
    return np.random.default_rng(seed).uniform(lo, hi, (n, asset.parameter_count))


def test_description(cubic, cases):
    assert [p.name for p in cubic.parameters] == ["bend", "twist"]
    assert cubic.parameters[0].unit == "1/m" and cubic.bounds.tolist() == [[0, 1], [0, 1]]
    assert [(f.name, f.location, f.components) for f in cubic.fields] == [
        ("temperature", "vertex", 1), ("stress", "tet", 1)]
    assert cubic.degree == 3 and cubic.element_count == 10 and cubic.parameter_count == 2
    assert [r.name for r in cubic.regions] == ["clamp", "tip load"]
    assert cubic.regions[0].kind == "fixed" and cubic.regions[0].face_tags.tolist() == [0]
    assert cubic.provenance.host == "synthetic box" and cubic.format_version == (1, 0)
    with cadinterp.Asset(cases / "valid" / "k1_units" / "asset.cadi") as units:
        assert [f.unit for f in units.fields] and all(f.unit for f in units.fields)
        assert units.format_version == (1, 1)
    assert cadinterp.version() == cadinterp.__version__
    assert cadinterp.format_version() >= (1, 1)


def test_infeasible_corner(cases, every_evaluation):
    # Infeasible points with messages are checked on a built asset (test_builder.py).
    with cadinterp.Asset(cases / "valid" / "k2_infeasible" / "asset.cadi") as a:
        X = points(a, 200, seed=2)
        feasible = np.array([a.locate(x)[1] for x in X])
        assert 0 < feasible.sum() < len(X), "the case has an infeasible corner"
        for x in X[~feasible][:5]:
            for call in every_evaluation(a, x):
                with pytest.raises(cadinterp.InfeasibleError):
                    call()
        assert all(m is None for m in a.eval_many(X[~feasible], errors="none"))


def test_eval_arrays(cubic):
    m = cubic.eval([0.3, 0.7])
    v, t, f = len(m.vertices), len(m.tets), len(m.triangles)
    assert m.vertices.dtype == np.float32 and m.vertices.shape == (v, 3)
    assert m.tets.dtype == np.uint32 and m.tets.shape == (t, 4) and m.tets.max() < v
    assert m.triangles.dtype == np.uint32 and m.triangles.shape == (f, 3)
    assert m.triangle_tags.dtype == np.int32 and m.triangle_tags.shape == (f,)
    assert list(m.fields) == ["temperature", "stress"]
    assert m.fields["temperature"].shape == (v,) and m.fields["stress"].shape == (t,)
    assert cubic.element_mesh_size(m.element) == (v, t, f)
    assert cubic.locate([0.3, 0.7]) == (m.element, True)
    for a in (m.vertices, m.tets, m.fields["stress"]):
        assert not a.flags.writeable  # views of the workspace and of the element cache
        with pytest.raises(ValueError):
            a[0] = 0


def test_field_selection(cubic):
    x = [0.3, 0.7]
    full = cubic.eval(x)
    assert list(cubic.eval(x, "stress").fields) == ["stress"]
    assert list(cubic.eval(x, [1, "temperature", 1]).fields) == ["stress", "temperature"]
    assert cubic.eval(x, []).fields == {}
    np.testing.assert_array_equal(cubic.eval(x, ["stress"]).fields["stress"], full.fields["stress"])


def test_inputs_are_converted(cubic):
    x = np.array([0.25, 0.5])
    want = cubic.eval(x).vertices.tobytes()
    for same in ([0.25, 0.5], (0.25, 0.5), np.array([0.25, 0.5], dtype=np.float32),
                 np.array([[0.25, 0.0], [0.5, 0.0]])[:, 0]):  # strided
        assert cubic.eval(same).vertices.tobytes() == want
    assert cubic.eval(np.array([0, 1])).vertices.shape[1] == 3  # integers


def test_results_never_change_under_later_evals(cubic):
    x1, x2 = [0.1, 0.2], [0.9, 0.8]
    first = cubic.eval(x1)
    before = first.vertices.copy(), first.fields["temperature"].copy()
    for _ in range(20):
        cubic.eval(x2)
        cubic.grad(x2)
    np.testing.assert_array_equal(first.vertices, before[0])
    np.testing.assert_array_equal(first.fields["temperature"], before[1])


def test_views_outlive_the_asset(cases):
    path = cases / "valid" / "k2_cubic" / "asset.cadi"
    a = cadinterp.Asset(path)
    m, g = a.eval([0.4, 0.6]), a.grad([0.4, 0.6])
    copies = [np.array(arr) for arr in (m.vertices, m.tets, m.fields["stress"], g.dvertices)]
    a.close()
    assert a.closed
    with pytest.raises(ValueError, match="closed"):
        a.eval([0.4, 0.6])
    a.close()  # idempotent
    del a
    vertices, tets, stress, dvertices = m.vertices, m.tets, m.fields["stress"], g.dvertices
    del m, g
    gc.collect()
    # The arrays still hold the asset (through their base): the values are all still there.
    for got, want in zip((vertices, tets, stress, dvertices), copies):
        np.testing.assert_array_equal(got, want)
    # The same from bytes opened in place: the bytes object lives as long as the views.
    data = path.read_bytes()
    b = cadinterp.Asset(data)
    v = b.eval([0.4, 0.6]).vertices
    del b, data
    gc.collect()
    np.testing.assert_array_equal(v, copies[0])


def test_sources(cases):
    path = cases / "valid" / "k2_linear" / "asset.cadi"
    want = cadinterp.Asset(str(path)).eval([0.5, 0.5]).vertices.tobytes()
    data = path.read_bytes()
    for source in (pathlib.Path(path), data, bytearray(data), memoryview(data),
                   np.frombuffer(data, dtype=np.uint8)):
        assert cadinterp.Asset(source).eval([0.5, 0.5]).vertices.tobytes() == want
    ba = bytearray(data)
    a = cadinterp.Asset(ba)  # other buffers are copied: changing them later is harmless
    ba[:] = bytes(len(ba))
    assert a.eval([0.5, 0.5]).vertices.tobytes() == want


def test_eval_many_equals_eval(cubic):
    X = points(cubic, 40)
    for threads in (1, 2, 0):
        many = cubic.eval_many(X, ["temperature"], threads=threads)
        assert len(many) == len(X)
        for x, m in zip(X, many):
            one = cubic.eval(x, ["temperature"])
            assert m.element == one.element
            assert m.vertices.tobytes() == one.vertices.tobytes()
            assert m.fields["temperature"].tobytes() == one.fields["temperature"].tobytes()


def test_eval_many_errors(cubic):
    X = points(cubic, 5)
    X[3] = [2.0, 0.5]
    with pytest.raises(cadinterp.OutsideDomainError, match=r"X\[3\]"):
        cubic.eval_many(X)
    many = cubic.eval_many(X, errors="none", threads=2)
    assert many[3] is None and all(m is not None for i, m in enumerate(many) if i != 3)


def test_grad_matches_finite_differences(cubic):
    x, h = np.array([0.37, 0.58]), 1e-4
    g = cubic.grad(x)
    assert g.vertices.tobytes() == cubic.eval(x).vertices.tobytes()
    assert g.dvertices.shape == (2,) + g.vertices.shape
    assert g.dfields["stress"].shape == (2, len(cubic.eval(x).tets))
    for d in range(2):
        e = np.eye(2)[d] * h
        fd = (cubic.eval(x + e).vertices.astype(float) - cubic.eval(x - e).vertices) / (2 * h)
        np.testing.assert_allclose(g.dvertices[d], fd, atol=2e-3)
        fd = (cubic.eval(x + e).fields["temperature"].astype(float) -
              cubic.eval(x - e).fields["temperature"]) / (2 * h)
        np.testing.assert_allclose(g.dfields["temperature"][d], fd, rtol=1e-2, atol=2e-2)


def test_vjp_is_the_contracted_jacobian(cubic):
    x = [0.37, 0.58]
    g = cubic.grad(x)
    rng = np.random.default_rng(3)
    w = rng.standard_normal(g.vertices.shape)
    ws = rng.standard_normal(g.dfields["stress"].shape[1:])
    got = cubic.vjp(x, dvertices=w, dfields={"stress": ws})
    want = (np.einsum("kvc,vc->k", g.dvertices.astype(float), w) +
            np.einsum("kt,t->k", g.dfields["stress"].astype(float), ws))
    np.testing.assert_allclose(got, want, rtol=1e-4, atol=1e-5)
    assert got.dtype == np.float64 and got.shape == (2,)
    np.testing.assert_array_equal(cubic.vjp(x), [0.0, 0.0])


def test_properties_and_their_gradient(cubic):
    # A step large enough that float32 positions do not swamp the difference (the asset is
    # cubic, so the central difference's own error is O(h^2)); x and x +- h share an element.
    x, h = np.array([0.4, 0.3]), 1e-2
    p = cubic.eval_properties(x, density=2.0, direction=(0, 0, 1), gradient=True)
    assert p["mass"] == pytest.approx(2.0 * p["volume"]) and p["volume"] > 0
    assert p["centroid"].shape == (3,) and p["inertia"].shape == (3, 3)
    grad = p["gradient"]
    assert grad["volume"].shape == (2,) and grad["inertia"].shape == (2, 3, 3)
    for d in range(2):
        e = np.eye(2)[d] * h
        up, down = (cubic.eval_properties(x + s * e, 2.0, (0, 0, 1)) for s in (1, -1))
        for key in ("volume", "area", "frontal_area"):
            assert grad[key][d] == pytest.approx((up[key] - down[key]) / (2 * h), rel=1e-2,
                                                 abs=1e-4)
    assert "gradient" not in cubic.eval_properties(x)


def test_error_estimate(cubic):
    e = cubic.error_estimate([0.5, 0.5])
    assert isinstance(e, float) and (np.isnan(e) or e >= 0)


def test_threads_share_one_asset(cubic):
    X = points(cubic, 64, seed=5)
    want = [cubic.eval(x).vertices.tobytes() for x in X]
    errors = []

    def worker(offset):
        try:
            for i in range(offset, len(X), 4):
                assert cubic.eval(X[i]).vertices.tobytes() == want[i]
        except Exception as e:  # reported by the main thread
            errors.append(e)

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
