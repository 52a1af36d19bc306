"""A Python host with a closed form, for the tests and the example's CI run: a tet-meshed box
of width w (x), height h (y) and depth 0.5 + 0.25 w^2 (z, nonlinear in x so the builder must
refine), on a fixed grid (so vertex i sits at the same grid coordinates (u, v, t) for every
x). Fields: 'temperature' per vertex, sin(w) (1 + X) + h Y at the vertex (X, Y, Z), and
'pressure' per tet, w + h. Every value at any x is known exactly (closed_form)."""
import itertools
import math

import numpy as np

import cadinterp

PARAMETERS = [("width", 1.0, 2.0, "mm"), ("height", 1.0, 2.0, "mm")]


def grid(n):
    """Grid coordinates (#V by 3 in [0,1]), positive tets, outward boundary triangles and their
    face tags (2 * axis + side) of the unit cube cut into n^3 cells of 6 tets each."""
    g = np.linspace(0.0, 1.0, n + 1)
    ref = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)

    def index(i, j, k):
        return (i * (n + 1) + j) * (n + 1) + k

    tets = []
    for i, j, k in itertools.product(range(n), repeat=3):
        for perm in itertools.permutations(range(3)):  # Kuhn's split along the main diagonal
            corner = [i, j, k]
            tet = [index(*corner)]
            for axis in perm:
                corner[axis] += 1
                tet.append(index(*corner))
            tets.append(tet)
    tets = np.array(tets, dtype=np.int64)
    p = ref[tets]
    det = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    tets[det < 0] = tets[det < 0][:, [0, 2, 1, 3]]
    faces = {}
    for t in tets:
        for opposite in range(4):
            face = tuple(t[[f for f in range(4) if f != opposite]])
            faces.setdefault(tuple(sorted(face)), []).append((face, t[opposite]))
    triangles, tags = [], []
    for owners in faces.values():
        if len(owners) != 1:
            continue
        (a, b, c), o = owners[0]
        if np.dot(np.cross(ref[b] - ref[a], ref[c] - ref[a]), ref[a] - ref[o]) < 0:
            b, c = c, b
        triangles.append((a, b, c))
        q = ref[[a, b, c]]
        axis = int(np.argmax(np.ptp(q, axis=0) == 0))
        tags.append(2 * axis + int(q[0, axis] > 0.5))
    return ref, tets, np.array(triangles, dtype=np.int64), np.array(tags, dtype=np.int32)


def closed_form(ref, x):
    """Positions, temperature (per vertex) and pressure (per tet value) at x."""
    w, h = x
    pos = ref * np.array([w, h, 0.5 + 0.25 * w * w])
    temperature = math.sin(w) * (1.0 + pos[:, 0]) + h * pos[:, 1]
    return pos, temperature, w + h


class BoxHost(cadinterp.Host):
    name = "python-box"
    identity = "box, closed form, grid 2"
    parameters = PARAMETERS
    thread_safe = True

    def __init__(self, cells=2, fail_above=None):
        self.ref, self.tets, self.triangles, self.tags = grid(cells)
        self.fail_above = fail_above  # regenerate raises where width and height both exceed it
        if fail_above is not None:
            self.identity += f", fails above {fail_above}"

    def regenerate(self, x):
        if self.fail_above is not None and min(x) > self.fail_above:
            raise ValueError(f"no box beyond {self.fail_above} (x = {list(x)})")
        pos, _, _ = closed_form(self.ref, x)
        return dict(vertices=pos, tets=self.tets, triangles=self.triangles,
                    triangle_tags=self.tags, note="extra keys reach references")

    def references(self, x, mesh):
        assert mesh["note"] == "extra keys reach references"
        corners = [i for i, r in enumerate(self.ref) if np.all((r == 0) | (r == 1))]
        points = [((0, i), mesh["vertices"][c]) for i, c in enumerate(corners)]
        return dict(points=points, regions=[("bottom", "fixed", [4]), ("top", "force", [5])])

    def simulate(self, x, mesh):
        pos = mesh["vertices"]
        temperature = math.sin(x[0]) * (1.0 + pos[:, 0]) + x[1] * pos[:, 1]
        pressure = np.full(len(mesh["tets"]), x[0] + x[1])
        return [dict(name="temperature", location="vertex", values=temperature, unit="K"),
                dict(name="pressure", location="tet", values=pressure, unit="Pa")]
