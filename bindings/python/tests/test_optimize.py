"""Asset.integral and cadinterp.Problem (the optimizer, libcadinterp_optimize) with its scipy
adapters, on the box host's asset: every quantity has a closed form (box_host.py), so the tests
compare against it, against central differences and against scipy.optimize."""
import math
import sys
import threading
import time

import numpy as np
import pytest

import cadinterp
from box_host import BoxHost

needs_optimizer = pytest.mark.skipif(not cadinterp._cadinterp.has_optimizer,
                                     reason="built without libcadinterp_optimize")
X = np.array([1.33, 1.22])  # inside an element of the linear asset: no kink within 1e-4


@pytest.fixture(scope="module")
def box(box_asset):
    with cadinterp.Asset(box_asset[0]) as a:
        yield a


@pytest.fixture(scope="module")
def cubic(tmp_path_factory):
    """The box host's asset of degree 3: C2 in x, as quasi-Newton methods expect (0.5 s)."""
    path = tmp_path_factory.mktemp("cubic") / "box3.cadi"
    cadinterp.build(BoxHost(), path, degree=3, geometry_tolerance=1e-3, field_tolerance=1e-3,
                    threads=2)
    with cadinterp.Asset(path) as a:
        yield a


def volume(x):  # the box's closed form (box_host.py): depth 0.5 + 0.25 w^2
    w, h = x
    return w * h * (0.5 + 0.25 * w * w)


def area(x):
    w, h = x
    d = 0.5 + 0.25 * w * w
    return 2 * (w * h + w * d + h * d)


def central(f, x, step=1e-4):
    e = np.eye(len(x)) * step
    return np.array([(f(x + e[i]) - f(x - e[i])) / (2 * step) for i in range(len(x))])


# ---- Asset.integral ------------------------------------------------------------------------------
def test_integral_of_one_is_the_volume_and_a_region_area(box):
    assert box.integral(X) == pytest.approx(box.eval_properties(X)["volume"], rel=1e-12)
    assert box.integral(X) == pytest.approx(volume(X), rel=2e-3)
    assert box.integral(X, region="top") == pytest.approx(X[0] * X[1], rel=1e-6)
    assert box.integral(X, region=1) == box.integral(X, region="top")


def test_integral_of_a_field_matches_its_closed_form(box):
    w, h = X
    # temperature sin(w) (1 + x) + h y is linear in position: its mean is its value at the centre
    exact = volume(X) * (math.sin(w) * (1 + w / 2) + h * h / 2)
    assert box.integral(X, "temperature") == pytest.approx(exact, rel=5e-3)
    assert box.integral(X, "pressure") == pytest.approx(volume(X) * (w + h), rel=5e-3)


@pytest.mark.parametrize("field,region", [(None, None), ("temperature", None),
                                          ("pressure", "bottom"), ("temperature", "top")])
def test_integral_gradient_matches_central_differences(box, field, region):
    value, grad = box.integral(X, field, region=region, grad=True)
    assert value == box.integral(X, field, region=region)
    fd = central(lambda x: box.integral(x, field, region=region), X)
    np.testing.assert_allclose(grad, fd, rtol=1e-3, atol=1e-6)
    props = box.eval_properties(X, gradient=True)["gradient"]["volume"]
    if field is None and region is None:
        np.testing.assert_allclose(grad, props, rtol=1e-9)


def test_integral_errors(box):
    with pytest.raises(cadinterp.NotFoundError, match="no region named 'side'"):
        box.integral(X, region="side")
    with pytest.raises(cadinterp.NotFoundError, match="no field named"):
        box.integral(X, "stress")
    with pytest.raises(cadinterp.InvalidArgumentError, match="component"):
        box.integral(X, "temperature", component=1)
    with pytest.raises(cadinterp.OutsideDomainError):
        box.integral([3.0, 1.0])


# ---- Problem ---------------------------------------------------------------------------------------
def known_minimizer():
    """argmin area subject to volume >= 3 of the closed form (scipy on the exact functions)."""
    from scipy.optimize import minimize
    r = minimize(area, [1.5, 1.5], method="SLSQP", bounds=[(1, 2), (1, 2)],
                 constraints=[{"type": "ineq", "fun": lambda x: volume(x) - 3}], tol=1e-9)
    assert r.success
    return r.x


def area_problem(box):
    p = cadinterp.Problem(box)
    p.minimize("area")
    assert p.subject_to("volume >= 3") == 1
    return p


@needs_optimizer
def test_solve_finds_the_known_minimizer_and_reports_every_field(cubic, box):
    r = area_problem(cubic).solve()
    assert r.converged and r.success and r.status.startswith("optimal")
    np.testing.assert_allclose(r.x, known_minimizer(), atol=5e-3)
    assert r.objective == pytest.approx(area(r.x), rel=2e-3)
    assert r.constraints[0] >= 3 - 1e-6 and r.constraint_violation < 1e-6
    assert r.path.shape == (len(r.path_objective), 2) and r.path.shape[0] >= 2
    np.testing.assert_array_equal(r.path[-1], r.x)
    assert r.iterations >= 1 and r.evaluations >= r.iterations and r.refused_evaluations == 0
    assert r.starts == 1 and r.best_start == 0 and r.ipopt_status == 0
    assert 0 < r.error_estimate < 1e-2
    assert not r.linear_asset and r.note == ""
    linear = area_problem(box).solve()  # C0: Ipopt still gets there, and the result says why
    assert linear.linear_asset and "C0" in linear.note
    np.testing.assert_allclose(linear.x, r.x, atol=5e-3)


@needs_optimizer
def test_scipy_agrees_with_ipopt(cubic):
    from scipy.optimize import minimize
    p = area_problem(cubic)
    ipopt = p.solve().x
    fun, jac = p.scipy_objective()
    slsqp = minimize(fun, [1.5, 1.5], jac=jac, method="SLSQP", bounds=p.bounds,
                     constraints=p.scipy_constraints(), tol=1e-6)
    assert slsqp.success, slsqp.message
    np.testing.assert_allclose(slsqp.x, ipopt, atol=2e-3)
    tc = minimize(p.fun, [1.5, 1.5], jac=p.jac, method="trust-constr", bounds=p.scipy_bounds(),
                  constraints=p.scipy_constraints("nonlinear"), options={"gtol": 1e-8})
    assert tc.success, tc.message
    np.testing.assert_allclose(tc.x, ipopt, atol=2e-3)
    np.testing.assert_allclose(ipopt, known_minimizer(), atol=2e-3)


@needs_optimizer
def test_evaluate_matches_central_differences_and_add_term_matches_parse(box):
    p = area_problem(box)
    e = p.evaluate(X)
    assert e.objective == pytest.approx(area(X), rel=2e-3)
    np.testing.assert_allclose(e.gradient, central(p.fun, X), rtol=1e-3)
    np.testing.assert_allclose(e.jacobian[0], central(lambda x: p.evaluate(x).constraints[0], X),
                               rtol=1e-3)
    q = cadinterp.Problem(box)
    q.add_term("area")
    j = q.add_constraint(lower=3)
    q.add_term("volume", function=j)
    f = q.evaluate(X)
    assert (f.objective, f.constraints[0]) == (e.objective, e.constraints[0])
    assert p.evaluate(X, gradient=False).gradient is None
    r = cadinterp.Problem(box)
    r.minimize("integral(temperature) - 2*region_area(top)")
    r.add_term("integral", weight=-1, field="temperature")
    assert r.fun(X) == pytest.approx(-2 * X[0] * X[1], rel=1e-5)


@needs_optimizer
def test_fix_and_bounds(box):
    p = area_problem(box)
    p.fix("width", 1.9)
    p.set_bounds(1, 1.0, 1.8)
    assert p.bounds == [(1.9, 1.9), (1.0, 1.8)]
    r = p.solve()
    assert r.x[0] == 1.9
    # volume 3 at width 1.9 needs height 3 / (1.9 (0.5 + 0.25 1.9^2)) = 1.126
    assert r.x[1] == pytest.approx(3 / (1.9 * (0.5 + 0.25 * 1.9**2)), abs=2e-3)
    with pytest.raises(cadinterp.InvalidArgumentError):
        p.set_bounds(0, 0.5, 1.5)  # outside the box


@needs_optimizer
def test_expression_errors_name_token_and_column(box):
    p = cadinterp.Problem(box)
    with pytest.raises(cadinterp.InvalidArgumentError, match=r"column 10: .*'mas'"):
        p.minimize("area + 2*mas")
    with pytest.raises(cadinterp.NotFoundError, match="stress"):
        p.minimize("integral(stress)")
    with pytest.raises(cadinterp.InvalidArgumentError, match="column"):
        p.subject_to("volume 3")
    with pytest.raises(ValueError, match="unknown quantity"):
        p.add_term("weight")
    assert p.constraint_count == 0 and p.fun(X) == 0


@needs_optimizer
def test_progress_callback_stops_and_refuses_a_nested_call(box):
    p = area_problem(box)
    seen = []
    r = p.solve(progress=lambda s, i, x, f, v, o: seen.append((s, i, x.copy(), f)) or i >= 2)
    assert [s[1] for s in seen] == [0, 1, 2] and not r.converged
    np.testing.assert_array_equal(seen[0][2], [1.5, 1.5])

    def nested(*args):
        p.evaluate(X)  # the problem is busy with the solve
    with pytest.raises(RuntimeError, match="in use"):
        p.solve(progress=nested)



@needs_optimizer
def test_solve_releases_the_gil(cubic):
    """Another Python thread runs while Ipopt does. No preemption (a switch interval of 10 s):
    the spinning thread runs only when the main thread gives the GIL up, so its count grows
    across solve() only if the solve releases the GIL."""
    p, count, done = area_problem(cubic), [0], threading.Event()

    def spin():
        while not done.is_set():
            count[0] += 1
            time.sleep(0)  # gives the GIL back at once

    old = sys.getswitchinterval()
    sys.setswitchinterval(10.0)
    t = threading.Thread(target=spin)
    t.start()
    try:
        while count[0] == 0:
            time.sleep(0.001)
        before = count[0]
        p.solve(multistart=8)
        after = count[0]
    finally:
        done.set()
        t.join()
        sys.setswitchinterval(old)
    assert after > before


@needs_optimizer
def test_multistart(cubic):
    r = area_problem(cubic).solve(start=[1.2, 1.9], multistart=3, max_iterations=50)
    assert r.starts == 3 and 0 <= r.best_start < 3
    np.testing.assert_allclose(r.x, known_minimizer(), atol=5e-3)
    with pytest.raises(cadinterp.InvalidArgumentError):
        area_problem(cubic).solve(multistart=0)
    with pytest.raises(TypeError, match="cadinterp.Asset"):
        cadinterp.Problem("box.cadi")


@needs_optimizer
def test_the_wall_of_an_infeasible_corner(tmp_path):
    path = tmp_path / "wall.cadi"
    cadinterp.build(BoxHost(fail_above=1.7), path, geometry_tolerance=1e-3, threads=2)
    with cadinterp.Asset(path) as a:
        p = cadinterp.Problem(a)
        p.minimize("-1*volume")  # the unconstrained optimum (2, 2) lies in the wall
        r = p.solve(start=[1.2, 1.2])
        assert r.refused_evaluations > 0  # the iterates ran into the wall
        assert a.locate(r.x)[1], r.x  # yet x is a point the runtime evaluates
        a.eval(r.x)
        assert r.objective < -volume([1.6, 1.6])
        with pytest.raises(cadinterp.InfeasibleError):
            p.fun([1.95, 1.95])
        with pytest.raises(cadinterp.InfeasibleError):
            p.evaluate([1.95, 1.95])


def test_without_the_optimizer_problem_says_so(box, monkeypatch):
    monkeypatch.setattr(cadinterp._optimize, "_Problem", None)
    with pytest.raises(cadinterp.OptimizerUnavailableError, match="without the optimizer"):
        cadinterp.Problem(box)
