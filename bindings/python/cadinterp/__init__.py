"""cadinterp: evaluate precomputed parametric CAD assets, and build them from hosts in Python.

    import cadinterp
    with cadinterp.Asset("bracket.cadi") as a:
        m = a.eval([30.0, 4.0])            # m.vertices, m.tets, m.triangles, m.fields[...]
        g = a.grad([30.0, 4.0])            # g.dvertices: K by #V by 3
    report = cadinterp.build(MyHost(), "out.cadi", geometry_tolerance=1e-3, threads=2)
    r = cadinterp.Problem(a).minimize("integral(von_mises) + 0.1*mass").solve()

A binding of the C ABI of libcadinterp (cadinterp.h), libcadinterp_builder (cadinterp_builder.h)
and libcadinterp_optimize (cadinterp_optimize.h); bindings/python/README.md is the reference.
"""
from ._errors import *  # noqa: F401,F403  (Error and one class per status)
from ._errors import __all__ as _error_names
from ._types import BuildReport, Field, InfeasiblePoint, Output, Parameter, Provenance, Region
from ._host import Host
from ._optimize import Evaluation, OptimizeResult, OptimizerUnavailableError, Problem
from ._cadinterp import (Asset, Gradient, Mesh, build, builder_version, format_version,
                         status_string, version)

__version__ = version()

__all__ = ["Asset", "Mesh", "Gradient", "build", "Host", "BuildReport", "Parameter", "Field",
           "Output", "Region", "InfeasiblePoint", "Provenance", "version", "builder_version",
           "format_version", "status_string", "Problem", "OptimizeResult", "Evaluation",
           "OptimizerUnavailableError"] + list(_error_names)
