"""cadinterp.Problem: shape optimization on an asset's interpolant with libcadinterp_optimize
(cadinterp_optimize.h; Ipopt), and adapters that hand the same objective, constraints and bounds
to scipy.optimize. bindings/python/README.md ("Optimization") is the reference."""
import dataclasses
import math
import re

import numpy as np

from . import _cadinterp
from ._errors import Error

_Problem = getattr(_cadinterp, "_Problem", None)

# cadinterp_optimize_quantity, by name (values are the C enum's).
QUANTITIES = {"volume": 0, "mass": 1, "area": 2, "frontal_area": 3, "centroid": 4,
              "inertia": 5, "integral": 6, "max_pnorm": 7, "max_ks": 8}


class OptimizerUnavailableError(Error, NotImplementedError):
    """This cadinterp was built without libcadinterp_optimize (Ipopt was not found, or
    CADINTERP_WITH_OPTIMIZE was OFF): cadinterp.Problem cannot be created."""


@dataclasses.dataclass
class OptimizeResult:
    """The outcome of Problem.solve: every field of cadinterp_optimize_result. `fun`, `success`,
    `message`, `nit` and `nfev` repeat objective, converged, status, iterations and evaluations
    under scipy.optimize.OptimizeResult's names."""
    x: np.ndarray                #: the optimum (a point the runtime evaluates)
    objective: float             #: at x
    constraints: np.ndarray      #: the constraint values at x
    constraint_violation: float  #: largest distance of a constraint outside its bounds
    gradient_norm: float         #: 2-norm of the objective's gradient over free parameters
    optimality: float            #: Ipopt's final scaled dual infeasibility (KKT error)
    converged: bool              #: Ipopt reported an optimum (to tolerance or acceptable)
    ipopt_status: int            #: Ipopt's ApplicationReturnStatus of the best start
    status: str                  #: that status in words
    iterations: int              #: Ipopt iterations, summed over starts
    evaluations: int             #: distinct points evaluated, summed over starts
    refused_evaluations: int     #: of those, the points the runtime refused (walls)
    starts: int                  #: starts run
    best_start: int              #: the start x comes from (0: `start` or the centre)
    path: np.ndarray             #: iterates of the best start, one row each
    path_objective: np.ndarray   #: the objective at each iterate
    error_estimate: object       #: the builder's relative geometric error at x, None: unmeasured
    linear_asset: bool           #: the interpolant is only C0 (see note)
    note: str                    #: a sentence on a linear asset's kinks, else ""

    fun = property(lambda self: self.objective)
    success = property(lambda self: self.converged)
    message = property(lambda self: self.status)
    nit = property(lambda self: self.iterations)
    nfev = property(lambda self: self.evaluations)


@dataclasses.dataclass
class Evaluation:
    """Problem.evaluate's answer at one x."""
    objective: float
    constraints: np.ndarray       #: m values
    gradient: np.ndarray = None   #: K values: d objective / dx (None without gradients)
    jacobian: np.ndarray = None   #: m by K: d constraints / dx (None without gradients)


class Problem:
    """Minimize an objective subject to constraints over an asset's parameter box.

        p = cadinterp.Problem(asset)
        p.minimize("integral(von_mises) + 0.1*mass")
        p.subject_to("mass <= 1.2e4")
        r = p.solve()                      # r.x, r.objective, r.status, r.path, ...

    The objective and each constraint are weighted sums of terms (cadinterp_optimize.h). One call
    at a time per problem (another call during a running one raises RuntimeError); the problem
    keeps the asset's data alive, also after asset.close().
    """

    QUANTITIES = QUANTITIES

    def __init__(self, asset):
        if _Problem is None:
            raise OptimizerUnavailableError(
                "this cadinterp was built without the optimizer: libcadinterp_optimize needs "
                "Ipopt (Debian: coinor-libipopt-dev; CMake option CADINTERP_WITH_OPTIMIZE)")
        if not isinstance(asset, _cadinterp.Asset):
            raise TypeError(f"Problem needs an opened cadinterp.Asset, got {type(asset).__name__}")
        self.asset = asset
        self._p = _Problem(asset)
        self._names = [p.name for p in asset.parameters]
        self._lower = np.array(asset.bounds[:, 0], dtype=float)
        self._upper = np.array(asset.bounds[:, 1], dtype=float)
        self._constraint_bounds = []  # (lower, upper) of constraint 1, 2, ...
        self._cache = None  # (x bytes, Evaluation with gradients): fun then jac at one x

    # ---- building the problem ----------------------------------------------------------------
    def minimize(self, expression):
        """Adds the terms of `expression` to the objective (cadinterp_optimize_parse's grammar,
        e.g. "integral(von_mises) + 0.1*mass(7.8e-9)"). A syntax error raises
        InvalidArgumentError, an unknown field or region NotFoundError; the message names the
        token and its column. Returns self."""
        self._p.parse(0, expression)
        self._cache = None
        return self

    def subject_to(self, constraint):
        """Adds the constraint "EXPR <= V", "EXPR >= V" or "EXPR == V"; returns its index
        (1, 2, ...; 0 is the objective). Errors as minimize."""
        function = self._p.parse_constraint(constraint)
        # Parsed by the C ABI, so the text ends with a comparison and a number: the last
        # comparison operator is the one.
        op, value = re.findall(r"(<=|>=|==)\s*([^<>=]*)$", constraint)[0]
        v = float(value)
        self._constraint_bounds.append({"<=": (-math.inf, v), ">=": (v, math.inf),
                                        "==": (v, v)}[op])
        self._cache = None
        return function

    def add_constraint(self, lower=-math.inf, upper=math.inf):
        """Adds a constraint lower <= g(x) <= upper with g = 0; add its terms with add_term(...,
        function=index). Returns its index."""
        function = self._p.add_constraint(lower, upper)
        self._constraint_bounds.append((float(lower), float(upper)))
        self._cache = None
        return function

    def add_term(self, quantity, *, function=0, weight=1.0, field=None, component=0,
                 region=None, parameter=1.0, direction=(0.0, 0.0, 1.0)):
        """Adds weight * quantity(x) to function `function` (0: the objective). quantity: one of
        QUANTITIES ('volume', 'mass', 'area', 'frontal_area', 'centroid', 'inertia', 'integral',
        'max_pnorm', 'max_ks'); field and region by name or index (None: -1); parameter is the
        density (mass, inertia), p (max_pnorm) or rho (max_ks)."""
        if quantity not in QUANTITIES:
            raise ValueError(f"unknown quantity {quantity!r} (one of {', '.join(QUANTITIES)})")
        self._p.add_term(function, QUANTITIES[quantity], weight, field, component, region,
                         parameter, direction)
        self._cache = None

    def _index(self, i):
        return self._names.index(i) if isinstance(i, str) else int(i)

    def set_bounds(self, i, lower, upper):
        """Narrows parameter i (index or name) to [lower, upper] inside the asset's box."""
        i = self._index(i)
        self._p.set_bounds(i, lower, upper)
        self._lower[i], self._upper[i] = lower, upper

    def fix(self, i, value):
        """Fixes parameter i (index or name) at value: Ipopt optimizes the others only."""
        self.set_bounds(i, value, value)

    @property
    def constraint_count(self):
        return self._p.constraint_count()

    @property
    def constraint_bounds(self):
        """(lower, upper) arrays of the constraints' bounds (-inf / inf: none)."""
        b = np.array(self._constraint_bounds, dtype=float).reshape(-1, 2)
        return b[:, 0], b[:, 1]

    # ---- evaluating ----------------------------------------------------------------------------
    def evaluate(self, x, gradient=True):
        """The objective and constraints at x (and their gradients) as an Evaluation.
        Raises InfeasibleError or OutsideDomainError where the runtime cannot evaluate x."""
        values, grads = self._p.evaluate(x, gradient)
        if grads is None:
            return Evaluation(float(values[0]), values[1:])
        return Evaluation(float(values[0]), values[1:], grads[0], grads[1:])

    def _at(self, x):
        key = np.asarray(x, dtype=float).tobytes()
        if self._cache is None or self._cache[0] != key:
            self._cache = (key, self.evaluate(x, gradient=True))
        return self._cache[1]

    def solve(self, start=None, multistart=1, max_iterations=200, tolerance=1e-6,
              progress=None, print_level=0):
        """Minimizes with Ipopt (without the GIL) and returns an OptimizeResult.
        start: K values inside the free ranges, or None (the centre); multistart: number of
        starts (N > 1 adds N - 1 Halton points); progress(start, iteration, x, objective,
        constraint_violation, optimality) is called once per iteration with the GIL held and
        stops that start when it returns True (an exception it raises stops the solve and is
        raised here). Raises InfeasibleError when no start can be evaluated."""
        d = self._p.solve(start, multistart, max_iterations, tolerance, print_level, progress)
        return OptimizeResult(**d)

    # ---- scipy.optimize ------------------------------------------------------------------------
    def fun(self, x):
        """The objective at x (scipy's `fun`); InfeasibleError where the runtime cannot
        evaluate x (scipy has no protocol for that: README, "Walls and scipy")."""
        return self._at(x).objective

    def jac(self, x):
        """The objective's gradient at x (scipy's `jac`), from the same evaluation as fun(x)."""
        return np.array(self._at(x).gradient)

    def scipy_objective(self):
        """(fun, jac) for scipy.optimize.minimize(fun, x0, jac=jac, ...)."""
        return self.fun, self.jac

    @property
    def bounds(self):
        """The free ranges as K (lower, upper) pairs: the sequence form scipy's `bounds` takes
        (fixed parameters have lower == upper)."""
        return list(zip(self._lower.tolist(), self._upper.tolist()))

    def scipy_bounds(self):
        """The free ranges as a scipy.optimize.Bounds."""
        from scipy.optimize import Bounds
        return Bounds(self._lower.copy(), self._upper.copy())

    def _constraint(self, j):
        return lambda x: float(self._at(x).constraints[j])

    def _constraint_jac(self, j):
        return lambda x: np.array(self._at(x).jacobian[j])

    def scipy_constraints(self, form="dict"):
        """The constraints in scipy's form: form='dict' gives the list of {'type': 'ineq' or
        'eq', 'fun', 'jac'} dicts of COBYLA/SLSQP (one per finite bound, g - lower >= 0 and
        upper - g >= 0); form='nonlinear' one scipy.optimize.NonlinearConstraint of all of them
        (trust-constr)."""
        lower, upper = self.constraint_bounds
        if form == "nonlinear":
            from scipy.optimize import NonlinearConstraint
            if not len(lower):
                return []
            return [NonlinearConstraint(lambda x: np.array(self._at(x).constraints),
                                        lower, upper,
                                        jac=lambda x: np.array(self._at(x).jacobian))]
        if form != "dict":
            raise ValueError(f"form must be 'dict' or 'nonlinear', got {form!r}")
        out = []
        for j, (lo, hi) in enumerate(zip(lower, upper)):
            g, dg = self._constraint(j), self._constraint_jac(j)
            if lo == hi:
                out.append({"type": "eq", "fun": lambda x, g=g, v=lo: g(x) - v, "jac": dg})
                continue
            if math.isfinite(lo):
                out.append({"type": "ineq", "fun": lambda x, g=g, v=lo: g(x) - v, "jac": dg})
            if math.isfinite(hi):
                out.append({"type": "ineq", "fun": lambda x, g=g, v=hi: v - g(x),
                            "jac": lambda x, dg=dg: -dg(x)})
        return out
