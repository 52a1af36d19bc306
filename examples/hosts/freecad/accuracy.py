"""Error measures of an interpolated mesh against the host's true one (README.md, "Results"),
the same definitions as the OpenCASCADE host's results tool:

- geometry: symmetric Hausdorff distance between the two boundary surfaces (exact point-to-
  triangle distances from every vertex and every triangle's centroid and edge midpoints of one
  surface to the other), relative to the true mesh's bounding-box diagonal;
- a field: |interpolated - true| at each evaluated vertex over the true field's range, the true
  value being the host's field interpolated linearly in the host's tet that contains the vertex
  (the one it is deepest in, barycentric coordinates clamped, when it lies just outside).
"""
import numpy as np
from scipy.spatial import cKDTree


def _point_triangle_distance(p, a, b, c):
    """Distances from points p (#N x 3) to triangles (a, b, c) (#N x 3 each), row by row
    (Ericson, Real-Time Collision Detection 5.1.5: closest point by Voronoi region)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v, w = vb / denom, vc / denom
        q = a + ab * v[:, None] + ac * w[:, None]  # inside the face
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    cases = [  # (condition, closest point), first match wins, in Ericson's order
        ((d1 <= 0) & (d2 <= 0), a),
        ((d3 >= 0) & (d4 <= d3), b),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * t_ab[:, None]),
        ((d6 >= 0) & (d5 <= d6), c),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * t_ac[:, None]),
        ((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), b + (c - b) * t_bc[:, None]),
    ]
    done = np.zeros(len(p), dtype=bool)
    for cond, point in cases:
        sel = cond & ~done
        q[sel] = point[sel]
        done |= sel
    return np.linalg.norm(p - q, axis=1)


def surface_samples(vertices, triangles):
    """Vertices, triangle centroids and edge midpoints of a triangle surface."""
    t = vertices[triangles]
    mids = np.concatenate([(t[:, 0] + t[:, 1]) / 2, (t[:, 1] + t[:, 2]) / 2, (t[:, 2] + t[:, 0]) / 2])
    return np.concatenate([vertices[np.unique(triangles)], t.mean(axis=1), mids])


def distance_to_surface(points, vertices, triangles):
    """Exact distance from each point to the triangle surface: the candidates are the triangles
    whose centroid lies within (distance to the nearest surface vertex + largest centroid-to-
    corner radius), which must contain the closest triangle."""
    t = vertices[triangles]
    centroid = t.mean(axis=1)
    radius = np.linalg.norm(t - centroid[:, None], axis=2).max()
    upper, _ = cKDTree(vertices[np.unique(triangles)]).query(points)
    tree = cKDTree(centroid)
    out = np.empty(len(points))
    for i, cand in enumerate(tree.query_ball_point(points, upper + radius + 1e-12)):
        cand = np.asarray(cand, dtype=np.int64)
        p = np.repeat(points[i][None], len(cand), axis=0)
        out[i] = _point_triangle_distance(p, t[cand, 0], t[cand, 1], t[cand, 2]).min()
    return out


def relative_hausdorff(mesh_a, mesh_b):
    """Symmetric Hausdorff distance between two boundary surfaces (dicts with vertices and
    triangles), over mesh_b's bounding-box diagonal."""
    va, ta = np.asarray(mesh_a["vertices"]), np.asarray(mesh_a["triangles"])
    vb, tb = np.asarray(mesh_b["vertices"]), np.asarray(mesh_b["triangles"])
    d = max(distance_to_surface(surface_samples(va, ta), vb, tb).max(),
            distance_to_surface(surface_samples(vb, tb), va, ta).max())
    return d / np.linalg.norm(vb.max(axis=0) - vb.min(axis=0))


def interpolate_in_tets(points, vertices, tets, values, candidates=24):
    """values (#V or #V x C, per vertex of the tet mesh) at `points`, linearly in the tet each
    point is deepest in among the `candidates` tets of nearest centroid."""
    t = vertices[tets]
    tree = cKDTree(t.mean(axis=1))
    _, cand = tree.query(points, k=min(candidates, len(tets)))
    a = t[cand, 0]
    m = np.stack([t[cand, 1] - a, t[cand, 2] - a, t[cand, 3] - a], axis=-1)  # N x k x 3 x 3
    lam123 = np.linalg.solve(m, (points[:, None, :] - a)[..., None])[..., 0]
    lam = np.concatenate([1 - lam123.sum(axis=-1, keepdims=True), lam123], axis=-1)
    best = lam.min(axis=-1).argmax(axis=1)
    rows = np.arange(len(points))
    lam = np.clip(lam[rows, best], 0, None)
    lam /= lam.sum(axis=1, keepdims=True)
    corners = tets[cand[rows, best]]
    vals = np.asarray(values)[corners]  # N x 4 (x C)
    return np.einsum("nk,nk...->n...", lam, vals)


def field_errors(points, values, true_mesh, true_values):
    """|values - true| at each point over the range of true_values (the magnitude's range for a
    vector field; per point the largest component error)."""
    truth = interpolate_in_tets(np.asarray(points), np.asarray(true_mesh["vertices"]),
                                np.asarray(true_mesh["tets"]), true_values)
    err = np.abs(np.asarray(values) - truth)
    if err.ndim == 2:
        err = err.max(axis=1)
    tv = np.asarray(true_values)
    span = np.ptp(np.linalg.norm(tv, axis=1) if tv.ndim == 2 else tv)
    return err / span
