"""Stable names of B-rep faces, edges and vertices of a FreeCAD solid, and the builder's
control-point IDs derived from them (README.md, "IDs"; include/cadinterp/cadinterp_builder.h).

FreeCAD 0.20 names sub-shapes by enumeration index (Face3, Edge7), which changes whenever the
topology does, and its Part::Cut keeps no usable history. So a face is named by the FEATURE whose
surface it lies on and the ROLE of that surface in the feature's own frame: "plate.ymax" is the
+y face of the Plate box, "hole.wall" the Hole cylinder's lateral face; a face on the surfaces of
several features (coplanar faces the fuse merged) has their roles joined, "plate.zmin+root.zmin".
A role shared by several faces (a face split in pieces) gets "#k" in geometric order. Edges and vertices are named by the
sorted roles of their adjacent faces ("E[hole.wall|plate.zmax]"), with "#k" in geometric order
only where several share them. Enumeration order never enters a name.
"""
import math

_TOL = 1e-6  # mm; coordinates are rounded to this before geometric ordering


def entity_id(label):
    """FNV-1a 64 of a label, masked to a non-negative int64 (the ID scheme's entity id)."""
    h = 0xCBF29CE484222325
    for b in label.encode("utf-8"):
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h & 0x7FFFFFFFFFFFFFFF


def face_tag(label):
    """A non-negative int32 face tag (triangle_tags, regions) from a face label."""
    h = entity_id(label)
    return (h ^ (h >> 31) ^ (h >> 62)) & 0x7FFFFFFF


def _key(v):
    """Geometric sort key of a point: coordinates rounded to _TOL."""
    return tuple(round(c / _TOL) for c in (v.x, v.y, v.z))


def _primitive_roles(prefix, shape):
    """[(role, face)] of a primitive: planar faces by their normal axis and side of the
    primitive's bounding box (xmin, xmax, ...), curved faces 'wall' (one per primitive here)."""
    box = shape.BoundBox
    roles = []
    for face in shape.Faces:
        surf = face.Surface
        if type(surf).__name__ == "Plane":
            n = surf.Axis
            axis = max(range(3), key=lambda i: abs(n[i]))
            c = face.CenterOfMass[axis]
            lo, hi = (box.XMin, box.XMax) if axis == 0 else (box.YMin, box.YMax) if axis == 1 \
                else (box.ZMin, box.ZMax)
            side = "min" if abs(c - lo) < abs(c - hi) else "max"
            roles.append(("%s.%s%s" % (prefix, "xyz"[axis], side), face))
        else:
            roles.append(("%s.wall" % prefix, face))
    return roles


def _same_support(face, prim, tol):
    """Whether `face` lies on the support surface of primitive face `prim` (same type, same
    defining geometry: a plane's normal line and offset; a cylinder's axis line and radius)."""
    a, b = face.Surface, prim.Surface
    ta, tb = type(a).__name__, type(b).__name__
    if ta != tb:
        return False
    if ta == "Plane":
        parallel = abs(abs(a.Axis.dot(b.Axis)) - 1) < 1e-9
        return parallel and abs((face.CenterOfMass - b.Position).dot(b.Axis)) < tol
    if ta == "Cylinder":
        parallel = abs(abs(a.Axis.dot(b.Axis)) - 1) < 1e-9
        d = a.Center - b.Center
        off_axis = (d - b.Axis * d.dot(b.Axis)).Length
        return parallel and off_axis < tol and abs(a.Radius - b.Radius) < tol
    raise ValueError("unsupported surface type %s" % ta)


def _numbered(items):
    """{key: label}: items is [(base label, sort key, key)]; a base label shared by several
    items gets '#k' in sort-key order, a unique one stays bare."""
    by_base = {}
    for base, order, key in items:
        by_base.setdefault(base, []).append((order, key))
    out = {}
    for base, group in by_base.items():
        group.sort(key=lambda g: g[0])
        for k, (_, key) in enumerate(group):
            out[key] = base if len(group) == 1 else "%s#%d" % (base, k)
    return out


class Names:
    """Names of one solid's entities. faces[i], edges[i], vertexes[i] are the labels of
    solid.Faces[i], solid.Edges[i], solid.Vertexes[i]; face_roles[i] the role of face i."""

    def __init__(self, solid, primitives, tol=1e-6):
        roles = [r for prefix, shape in primitives for r in _primitive_roles(prefix, shape)]
        self.face_roles = []
        for face in solid.Faces:
            match = sorted({role for role, prim in roles if _same_support(face, prim, tol)})
            if not match:
                raise ValueError("face at %s lies on no feature's surface" % face.CenterOfMass)
            self.face_roles.append("+".join(match))
        faces = _numbered([(r, _key(f.CenterOfMass), i)
                           for i, (r, f) in enumerate(zip(self.face_roles, solid.Faces))])
        self.faces = [faces[i] for i in range(len(solid.Faces))]
        if len({face_tag(l) for l in self.faces}) != len(self.faces):
            raise ValueError("face tag collision among %s" % self.faces)

        def adjacent_roles(sub):
            # Face roles around an edge or vertex, found by shared geometry (isSame).
            return sorted(self.face_roles[i] for i, f in enumerate(solid.Faces)
                          if any(s.isSame(sub) for s in (f.Edges if sub.ShapeType == "Edge"
                                                         else f.Vertexes)))

        edges = _numbered([("E[%s]" % "|".join(adjacent_roles(e)), _key(e.CenterOfMass), i)
                           for i, e in enumerate(solid.Edges)])
        self.edges = [edges[i] for i in range(len(solid.Edges))]
        verts = _numbered([("V[%s]" % "|".join(adjacent_roles(v)), _key(v.Point), i)
                           for i, v in enumerate(solid.Vertexes)])
        self.vertexes = [verts[i] for i in range(len(solid.Vertexes))]


def _index_of(shapes, sub):
    for i, s in enumerate(shapes):
        if s.isSame(sub):
            return i
    raise ValueError("sub-shape not found in its solid")


def control_points(solid, names, levels=1):
    """The ID scheme of cadinterp_builder.h on `solid`: returns (points, edges) where points is
    [(id list, (x, y, z))] and edges is [(edge, [(u, id)], t_lo, t_hi)] for each edge: its
    control points at normalized parameters u in [0, 1] (ends included) from the lower-id end.
    Vertices: {0, vid, sorted ids of adjacent edges}; edge interior: {1, eid, sorted end ids, -1,
    i_1..i_n} at the midpoints of the hierarchical subdivision, n = 0..levels."""
    eid = [entity_id(l) for l in names.edges]
    vid = [entity_id(l) for l in names.vertexes]
    vertex_ids = []
    for i, v in enumerate(solid.Vertexes):
        adj = sorted({eid[_index_of(solid.Edges, e)] for e in solid.ancestorsOfType(v, type(solid.Edges[0]))
                      if not e.Degenerated})
        vertex_ids.append([0, vid[i]] + adj)
    points = [(vertex_ids[i], tuple(v.Point)) for i, v in enumerate(solid.Vertexes)]
    edges = []
    for i, e in enumerate(solid.Edges):
        if e.Degenerated:
            continue
        v1, v2 = e.Vertexes[0], e.Vertexes[-1]
        i1, i2 = _index_of(solid.Vertexes, v1), _index_of(solid.Vertexes, v2)
        p1, p2 = e.ParameterRange
        if i1 != i2:
            p1, p2 = e.parameterAt(v1), e.parameterAt(v2)
        flip = vid[i2] < vid[i1]
        t_lo, t_hi = (p2, p1) if flip else (p1, p2)
        lo, hi = (i2, i1) if flip else (i1, i2)
        base = [1, eid[i], min(vid[i1], vid[i2]), max(vid[i1], vid[i2]), -1]
        along = [(0.0, vertex_ids[lo]), (1.0, vertex_ids[hi])]
        for n in range(levels + 1):
            for bits in range(1 << n):
                path = [(bits >> k) & 1 for k in range(n - 1, -1, -1)]
                a, b = 0.0, 1.0
                for bit in path:
                    mid = 0.5 * (a + b)
                    a, b = (mid, b) if bit else (a, mid)
                u = 0.5 * (a + b)
                along.append((u, base + path))
                p = e.valueAt(t_lo + u * (t_hi - t_lo))
                points.append((base + path, (p.x, p.y, p.z)))
        along.sort(key=lambda a: a[0])
        edges.append((e, along, t_lo, t_hi))
    return points, edges
