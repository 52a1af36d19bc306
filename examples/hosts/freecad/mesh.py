"""Linear tet meshing of a FreeCAD solid with Gmsh (README.md, "Meshing").

The solid goes to Gmsh as BREP (FreeCAD's exportBrep, Gmsh's OpenCASCADE importer), so Gmsh
meshes the same B-rep FreeCAD computed. Gmsh's surfaces and curves are mapped back to the
solid's faces and edges by geometry (centre of mass and size), never by index: Gmsh may renumber
what it imports.
"""
import os
import tempfile

import gmsh  # imported at module load: gmsh installs a SIGINT handler, allowed on the main thread only
import numpy as np

_initialized = False


def _gmsh():
    global _initialized
    if not _initialized:
        gmsh.initialize([], False)
        gmsh.option.setNumber("General.Terminal", 0)
        _initialized = True
    return gmsh


def _match(entities, shapes, what):
    """{gmsh tag: index in shapes} matching each Gmsh entity (dim, tag) to the shape with the
    same centre of mass and size (area or length)."""
    out = {}
    for dim, tag in entities:
        com = np.array(gmsh.model.occ.getCenterOfMass(dim, tag))
        size = gmsh.model.occ.getMass(dim, tag)
        best, err = None, None
        for i, s in enumerate(shapes):
            m = s.Area if dim == 2 else s.Length
            e = np.linalg.norm(com - np.array(tuple(s.CenterOfMass))) + abs(size - m)
            if err is None or e < err:
                best, err = i, e
        if err is None or err > 1e-6 * (1 + size):
            raise RuntimeError("gmsh %s %d matches no FreeCAD %s (error %g)" % (what, tag, what, err))
        out[tag] = best
    if len(set(out.values())) != len(out) or len(out) != len(shapes):
        raise RuntimeError("gmsh has %d %ss for FreeCAD's %d" % (len(out), what, len(shapes)))
    return out


def _outward_boundary(tets):
    """Triangles on the boundary of a positively oriented tet mesh, counter-clockwise seen from
    outside: the faces used by exactly one tet, each taken with that tet's outward order."""
    faces = np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 3, 2]], tets[:, [0, 1, 3]],
                            tets[:, [0, 2, 1]]])
    key = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return faces[counts[inverse.ravel()] == 1]


def tet_mesh(solid, face_tags, size, divisions=1):
    """Meshes `solid` with linear tets of target edge length `size` (mm); every B-rep edge gets
    a multiple of `divisions` segments uniform in arc length, so its points at fractions
    j / divisions are mesh vertices (the control points of naming.control_points with
    divisions = 2^(levels+1): the mapper anchors only control points that are mesh vertices).
    Returns (mesh, edge_nodes):
    mesh = dict(vertices #V x 3, tets #T x 4 (det > 0), triangles #F x 3 (outward), triangle_tags
    #F (face_tags[i] for a triangle on solid.Faces[i])); edge_nodes[i] = #N x 3 mesh vertex
    positions on solid.Edges[i], ends included. Raises RuntimeError when Gmsh fails."""
    g = _gmsh()
    g.clear()
    g.option.setNumber("Mesh.MeshSizeMax", size)
    g.option.setNumber("Mesh.MeshSizeMin", size / 10)
    g.option.setNumber("Mesh.MeshSizeFromCurvature", 12)  # elements per 2 pi on curved faces
    g.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay: deterministic, robust
    g.option.setNumber("General.NumThreads", 1)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "solid.brep")
        solid.exportBrep(path)
        g.model.occ.importShapes(path)
    g.model.occ.synchronize()
    face_of = _match(g.model.getEntities(2), solid.Faces, "face")
    edges = [e for e in solid.Edges if not e.Degenerated]
    edge_of = _match(g.model.getEntities(1), edges, "edge")
    for _, ctag in g.model.getEntities(1):
        # Lines and circular arcs only (the model's edges): arc length is uniform in the curve
        # parameter, so Gmsh's uniform nodes fall on the parameter fractions of the ID scheme.
        length = edges[edge_of[ctag]].Length
        segments = divisions * max(1, int(np.ceil(length / (size * divisions))))
        g.model.mesh.setTransfiniteCurve(ctag, segments + 1)
    g.model.mesh.generate(3)

    node_tags, coords, _ = g.model.mesh.getNodes()
    index = np.full(int(node_tags.max()) + 1, -1, dtype=np.int64)
    index[node_tags.astype(np.int64)] = np.arange(len(node_tags))
    vertices = coords.reshape(-1, 3)
    tets = []
    for etype, _, enodes in zip(*g.model.mesh.getElements(3)):
        if etype != 4:
            raise RuntimeError("gmsh produced volume elements of type %d, not linear tets" % etype)
        tets.append(index[enodes.astype(np.int64)].reshape(-1, 4))
    if not tets:
        raise RuntimeError("gmsh produced no tets")
    tets = np.concatenate(tets)
    a, b, c, d = (vertices[tets[:, k]] for k in range(4))
    det = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)
    tets[det < 0] = tets[det < 0][:, [0, 2, 1, 3]]

    tag_of_key = {}
    for dim, stag in g.model.getEntities(2):
        for etype, _, enodes in zip(*g.model.mesh.getElements(dim, stag)):
            tri = index[enodes.astype(np.int64)].reshape(-1, 3)
            for t in np.sort(tri, axis=1):
                tag_of_key[tuple(t)] = face_tags[face_of[stag]]
    triangles = _outward_boundary(tets)
    if len(triangles) != len(tag_of_key):
        raise RuntimeError("tet boundary has %d triangles, gmsh's surfaces %d"
                           % (len(triangles), len(tag_of_key)))
    tags = np.array([tag_of_key[tuple(t)] for t in np.sort(triangles, axis=1)], dtype=np.int32)

    edge_nodes = [None] * len(solid.Edges)
    edge_index = [i for i, e in enumerate(solid.Edges) if not e.Degenerated]
    for _, ctag in g.model.getEntities(1):
        tags_on, _, _ = g.model.mesh.getNodes(1, ctag, includeBoundary=True)
        edge_nodes[edge_index[edge_of[ctag]]] = vertices[index[tags_on.astype(np.int64)]]

    # Compact: keep only vertices the tets use (Gmsh keeps none unused for a solid, but checked).
    used = np.unique(tets)
    if len(used) != len(vertices):
        remap = np.full(len(vertices), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        vertices, tets, triangles = vertices[used], remap[tets], remap[triangles]
    mesh = dict(vertices=np.ascontiguousarray(vertices, dtype=np.float64),
                tets=tets.astype(np.int64), triangles=triangles.astype(np.int64),
                triangle_tags=tags)
    return mesh, edge_nodes
