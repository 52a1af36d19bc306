"""A cadinterp host written in Python over FreeCAD 0.20, Gmsh and CalculiX (README.md).

    import freecad_host, cadinterp
    host = freecad_host.BracketHost(mesh_size=2.5)
    cadinterp.build(host, "bracket.cadi", store="bracket.sqlite")

The host follows the duck-typed protocol of the Python binding: name, identity, parameters,
thread_safe, regenerate(x) -> mesh dict, references(x, mesh) -> points/paths/regions,
simulate(x, mesh) -> fields. Any exception makes x infeasible with its message.
"""
import math

import numpy as np

import bracket_model
import calculix
import mesh as meshing
import naming

FORCE_N = 100.0  # total load on the tip face, -z


def _parameter_on(edge, t_lo, t_hi, point):
    """Normalized parameter u in [0, 1] of `point` (on `edge`) along t_lo -> t_hi; a periodic
    curve's parameter is shifted by periods into the edge's range."""
    import FreeCAD
    t = edge.Curve.parameter(FreeCAD.Vector(*point))
    if edge.Curve.isPeriodic():
        period = edge.Curve.period()
        lo = min(t_lo, t_hi)
        t = lo + math.fmod(t - lo, period) % period
    return (t - t_lo) / (t_hi - t_lo)


class BracketHost:
    """The stepped cantilever with a hole that crosses the step (bracket_model.py).
    Not thread-safe: one FreeCAD document and one Gmsh session per process."""

    name = "freecad-bracket"
    parameters = bracket_model.PARAMETERS
    thread_safe = False

    def __init__(self, mesh_size=2.5, levels=1):
        if not mesh_size > 0 or levels not in range(0, 5):
            raise ValueError("mesh_size must be > 0 and levels in 0..4")
        self.mesh_size, self.levels = float(mesh_size), int(levels)
        # Every setting that changes a sample is in the identity, so a store of others is refused.
        self.identity = ("stepped bracket v1 (FreeCAD 0.20: spreadsheet, boxes fused, cylinder cut); gmsh size %g; "
                         "levels %d; ccx C3D10 steel, tip force %g N" % (mesh_size, levels, FORCE_N))
        self.doc = bracket_model.BracketDocument()
        self._last = None  # (x tuple, solid, names, mesh, edge_nodes) of the last regenerate

    def _evaluate(self, x):
        key = tuple(float(v) for v in x)
        if self._last is None or self._last[0] != key:
            solid, primitives = self.doc.regenerate(key)
            names = naming.Names(solid, primitives)
            tags = [naming.face_tag(label) for label in names.faces]
            mesh, edge_nodes = meshing.tet_mesh(solid, tags, self.mesh_size, 2 ** (self.levels + 1))
            self._last = (key, solid, names, mesh, edge_nodes)
        return self._last

    def regenerate(self, x):
        """The linear tet mesh of the model at x: vertices, tets (det > 0), outward boundary
        triangles and their face tags (naming.face_tag of the face's stable label)."""
        return dict(self._evaluate(x)[3])

    def references(self, x, mesh=None):
        """Control points (vertices and edge subdivision points, the ID scheme of
        cadinterp_builder.h over naming.py's labels), paths along every edge through the mesh's
        edge nodes, and the regions 'root' (fixed: the x = 0 face) and 'tip' (force: the
        x = length face)."""
        _, solid, names, _, edge_nodes = self._evaluate(x)
        points, edges = naming.control_points(solid, names, self.levels)
        position = {tuple(pid): p for pid, p in points}
        paths = []
        for e, along, t_lo, t_hi in edges:
            index = next(i for i, s in enumerate(solid.Edges) if s.isSame(e))
            nodes = sorted((_parameter_on(e, t_lo, t_hi, p), tuple(p)) for p in edge_nodes[index])
            # Each control point is the mesh node at its fraction of the edge (tet_mesh put one
            # there; Gmsh's arc-length placement may differ from the exact point by rounding).
            for u, pid in along:
                node = min(nodes, key=lambda n: abs(n[0] - u))
                if abs(node[0] - u) * e.Length < 1e-3 * self.mesh_size:
                    position[tuple(pid)] = node[1]
            for (ua, ida), (ub, idb) in zip(along, along[1:]):
                poly = [position[tuple(ida)]]
                poly += [p for u, p in nodes if ua + 1e-9 < u < ub - 1e-9]
                poly.append(position[tuple(idb)])
                paths.append((ida, idb, np.array(poly, dtype=np.float64)))
        points = [(pid, position[tuple(pid)]) for pid, _ in points]
        regions = [
            ("root", "fixed", self._tags(names, bracket_model.FIXED_ROLE)),
            ("tip", "force", self._tags(names, bracket_model.LOAD_ROLE)),
        ]
        return dict(points=points, paths=paths, regions=regions)

    @staticmethod
    def _tags(names, role):
        return [naming.face_tag(l) for l, r in zip(names.faces, names.face_roles) if r == role]

    def simulate(self, x, mesh):
        """CalculiX on `mesh` (this x's own, or another sample's mapped to x): the x = 0 face
        clamped, FORCE_N down (-z) spread over the x = length face. Fields per vertex: von_mises
        (MPa) and displacement (3 components, mm). The faces are found by their tags, which name
        the two end faces at every x (they are never split)."""
        u, vm = calculix.solve(mesh, [naming.face_tag(bracket_model.FIXED_ROLE)],
                               [naming.face_tag(bracket_model.LOAD_ROLE)], (0.0, 0.0, -FORCE_N))
        return [dict(name="von_mises", location="vertex", values=vm, unit="MPa"),
                dict(name="displacement", location="vertex", values=u, unit="mm")]
