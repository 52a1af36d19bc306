"""Hosts written in Python: the optional base class, and the adapter the extension module calls
from the builder's callbacks (cadinterp.build). The adapter checks what a host returns and
converts it to the dtypes and layout of the C ABI (cadinterp_builder.h), so that a mistake in a
host is a clear message on an infeasible point, never a crash or a silently wrapped index.

The protocol (bindings/python/README.md has the full reference):

    class MyHost(cadinterp.Host):         # or any object with these attributes
        name = "bracket"                  # required, non-empty
        identity = "bracket v1, mesh 2"   # optional; a sample store of another identity is refused
        parameters = [("width", 20.0, 40.0, "mm"), ("hole", 2.0, 6.0)]  # (name, lower, upper[, unit])
        thread_safe = False               # optional; True: callbacks may run concurrently
        def regenerate(self, x):          # x: float64 array of K values
            return dict(vertices=..., tets=..., triangles=..., triangle_tags=...,
                        outputs={"brep_volume": (v, "mm^3")})  # optional: exact scalars

        def references(self, x, mesh):    # optional; mesh: regenerate's dict, arrays converted
            return dict(points=[(id, (px, py, pz))], paths=[(id_a, id_b, polyline)],
                        regions=[(name, kind, face_tags)])                  # each key optional
        def simulate(self, x, mesh):      # optional; mesh: vertices, tets, triangles, triangle_tags
            return [dict(name="von_mises", location="vertex", values=..., unit="MPa")]
"""
import math
from collections.abc import Mapping

import numpy as np

_MAX_INDEX = np.iinfo(np.uint32).max
_MAX_ID_LENGTH = 64


class Host:
    """Optional base class of a Python host: the defaults of the optional attributes. Define
    `name`, `parameters` and `regenerate`; add `references` and `simulate` when the model has
    them (they are looked up by name, so the base class defines neither)."""

    name = None
    identity = ""
    parameters = ()
    thread_safe = False

    def regenerate(self, x):
        raise NotImplementedError(f"{type(self).__name__}.regenerate(x) is not defined")


def _callable_attr(host, name, required):
    fn = getattr(host, name, None)
    if fn is None and not required:
        return None
    if not callable(fn):
        raise TypeError(f"the host has no method {name}(...)"
                        if fn is None else f"the host's {name} is not callable")
    return fn


def describe(host):
    """(name, identity, [(name, lower, upper, unit)], thread_safe, has references, has simulate)."""
    name = getattr(host, "name", None)
    if not isinstance(name, str) or not name:
        raise TypeError("the host needs a `name`: a non-empty str")
    identity = getattr(host, "identity", "") or ""
    if not isinstance(identity, str):
        raise TypeError("the host's `identity` must be a str")
    params = []
    for i, p in enumerate(getattr(host, "parameters", None) or ()):
        if isinstance(p, (str, bytes)) or not 3 <= len(p) <= 4:
            raise ValueError(f"parameter {i} must be (name, lower, upper[, unit]), got {p!r}")
        pname, lower, upper = p[0], float(p[1]), float(p[2])
        unit = p[3] if len(p) == 4 and p[3] is not None else ""
        if not isinstance(pname, str) or not pname or not isinstance(unit, str):
            raise ValueError(f"parameter {i}: the name (non-empty) and unit must be str, got {p!r}")
        if not (math.isfinite(lower) and math.isfinite(upper) and lower < upper):
            raise ValueError(f"parameter '{pname}': needs finite lower < upper, "
                             f"got [{lower}, {upper}]")
        params.append((pname, lower, upper, unit))
    if not 1 <= len(params) <= 8:
        raise ValueError(f"the host needs 1 to 8 parameters, got {len(params)}")
    _callable_attr(host, "regenerate", True)
    has_references = _callable_attr(host, "references", False) is not None
    has_simulate = _callable_attr(host, "simulate", False) is not None
    return (name, identity, params, bool(getattr(host, "thread_safe", False)), has_references,
            has_simulate)


def _reals(value, what, cols=None):
    a = np.asarray(value)
    if a.dtype.kind not in "fiu":
        raise TypeError(f"{what} must be real numbers, got dtype {a.dtype}")
    a = np.ascontiguousarray(a, dtype=np.float64)
    if cols is not None and (a.ndim != 2 or a.shape[1] != cols):
        raise ValueError(f"{what} must have shape (N, {cols}), got {a.shape}")
    return a


def _integers(value, what, dtype, cols=None, below=None):
    a = np.asarray(value)
    if a.size == 0 and a.dtype.kind == "f":
        a = a.astype(np.int64)  # an empty list comes as float64
    if a.dtype.kind not in "iu":
        raise TypeError(f"{what} must be integers, got dtype {a.dtype}")
    if cols is not None and (a.ndim != 2 or a.shape[1] != cols):
        raise ValueError(f"{what} must have shape (N, {cols}), got {a.shape}")
    if cols is None and a.ndim != 1:
        raise ValueError(f"{what} must be a 1-D array, got shape {a.shape}")
    info = np.iinfo(dtype)
    low, high = info.min, info.max if below is None else below - 1
    if a.size and (a.min() < low or a.max() > high):
        raise ValueError(f"{what} must lie in [{low}, {high}], got values in "
                         f"[{a.min()}, {a.max()}]")
    return np.ascontiguousarray(a, dtype=dtype)


def _mapping(value, what, keys):
    if not isinstance(value, Mapping):
        raise TypeError(f"{what} must return a dict, got {type(value).__name__}")
    unknown = set(value) - set(keys)
    if unknown:
        raise ValueError(f"{what} returned unknown keys {sorted(unknown)} (known: {list(keys)})")
    return value


_MESH_KEYS = ("vertices", "tets", "triangles", "triangle_tags")


def _outputs(value):
    """regenerate's optional "outputs": {name: value or (value, unit)}, checked: [(name, value,
    unit)] in the dict's order (every sample must give the same names in the same order)."""
    if value is None:
        return []
    if not isinstance(value, Mapping):
        raise TypeError("regenerate's outputs must be a dict {name: value or (value, unit)}")
    out = []
    for name, v in value.items():
        unit = ""
        if isinstance(v, tuple):
            if len(v) != 2:
                raise ValueError(f"output '{name}': give a value or (value, unit)")
            v, unit = v
        if not isinstance(name, str) or not name or not isinstance(unit, str):
            raise ValueError("an output's name (non-empty) and unit must be str")
        v = float(v)
        if not math.isfinite(v):
            raise ValueError(f"output '{name}' is not finite: {v}")
        out.append((name, v, unit))
    return out


def regenerate(host, x):
    """host.regenerate(x), checked: (mesh dict for references, vertices, tets, triangles, tags,
    [(output name, value, unit)])."""
    mesh = host.regenerate(x)
    if not isinstance(mesh, Mapping):
        raise TypeError(f"regenerate must return a dict, got {type(mesh).__name__}")
    missing = [k for k in _MESH_KEYS if k not in mesh]
    if missing:
        raise ValueError(f"regenerate returned no {', '.join(missing)}")
    v = _reals(mesh["vertices"], "regenerate's vertices", cols=3)
    n = min(len(v), _MAX_INDEX + 1)
    t = _integers(mesh["tets"], "regenerate's tets", np.uint32, cols=4, below=n)
    f = _integers(mesh["triangles"], "regenerate's triangles", np.uint32, cols=3, below=n)
    tags = _integers(mesh["triangle_tags"], "regenerate's triangle_tags", np.int32)
    if len(tags) != len(f):
        raise ValueError(f"regenerate returned {len(f)} triangles but {len(tags)} triangle_tags")
    # The host's own dict (extra keys kept, e.g. a kernel's shape for references), with the
    # four arrays as the builder got them.
    converted = dict(mesh)
    converted.update(vertices=v, tets=t, triangles=f, triangle_tags=tags)
    return converted, v, t, f, tags, _outputs(mesh.get("outputs"))


def _id(value, what):
    a = _integers(value, what, np.int64)
    if not 1 <= len(a) <= _MAX_ID_LENGTH:
        raise ValueError(f"{what} must hold 1 to {_MAX_ID_LENGTH} integers, got {len(a)}")
    return a


def references(host, x, mesh):
    """host.references(x, mesh), checked: ([(id, position)], [(id_a, id_b, polyline)],
    [(name, kind, face_tags)])."""
    r = host.references(x, mesh)
    if r is None:
        return [], [], []
    r = _mapping(r, "references", ("points", "paths", "regions"))
    points, paths, regions = [], [], []
    for i, item in enumerate(r.get("points") or ()):
        pid, pos = item
        pos = _reals(pos, f"references' point {i} position").reshape(-1)
        if pos.shape != (3,):
            raise ValueError(f"references' point {i}: the position must be 3 numbers")
        points.append((_id(pid, f"references' point {i} id"), pos))
    for i, item in enumerate(r.get("paths") or ()):
        id_a, id_b, line = item
        line = _reals(line, f"references' path {i} polyline", cols=3)
        if len(line) < 2:
            raise ValueError(f"references' path {i}: the polyline needs at least 2 points")
        paths.append((_id(id_a, f"references' path {i} id_a"),
                      _id(id_b, f"references' path {i} id_b"), line))
    for i, item in enumerate(r.get("regions") or ()):
        name, kind, tags = item
        if not isinstance(name, str) or not name or not isinstance(kind or "", str):
            raise ValueError(f"references' region {i}: name (non-empty) and kind must be str")
        regions.append((name, kind or "", _integers(tags, f"region '{name}' face_tags", np.int32)))
    return points, paths, regions


_LOCATIONS = {"vertex": 0, "tet": 1}  # cadinterp_field_location


def simulate(host, x, mesh):
    """host.simulate(x, mesh), checked: [(name, location, components, values, rows, unit)] with
    values flat float64."""
    fields = host.simulate(x, mesh)
    if isinstance(fields, Mapping) or not hasattr(fields, "__iter__"):
        raise TypeError("simulate must return a list of dicts (name, location, values[, unit])")
    out = []
    for i, f in enumerate(fields):
        f = _mapping(f, f"simulate's field {i}", ("name", "location", "values", "unit"))
        name, location, unit = f.get("name"), f.get("location", "vertex"), f.get("unit") or ""
        if not isinstance(name, str) or not name or not isinstance(unit, str):
            raise ValueError(f"simulate's field {i}: name (non-empty) and unit must be str")
        if location not in _LOCATIONS:
            raise ValueError(f"field '{name}': location must be 'vertex' or 'tet', got {location!r}")
        values = _reals(f.get("values"), f"field '{name}' values")
        if values.ndim not in (1, 2):
            raise ValueError(f"field '{name}': values must be N or N by C, got {values.shape}")
        components = 1 if values.ndim == 1 else values.shape[1]
        out.append((name, _LOCATIONS[location], components, values.reshape(-1), len(values), unit))
    return out
