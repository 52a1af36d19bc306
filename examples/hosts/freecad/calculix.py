"""Linear-elastic analysis of a tet mesh with CalculiX (ccx), README.md "Simulation".

The linear mesh is raised to quadratic tets (C3D10, midside nodes at the straight edges'
midpoints: linear tets are far too stiff in bending), one face region is clamped and a total force
is spread over another as a uniform traction (the consistent nodal loads of a 6-node triangle:
A/3 on each midside node, none on the corners). ccx runs in a temporary directory; the nodal
displacements and von Mises stresses (ccx's stresses extrapolated to and averaged at the nodes)
are read from its .frd file at the linear mesh's vertices.
"""
import os
import shutil
import subprocess
import tempfile

import numpy as np

YOUNG, POISSON = 210000.0, 0.3  # steel, MPa
_C3D10_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]  # ccx's midside node order
_TRI6_EDGES = [(0, 1), (1, 2), (2, 0)]


def ccx_path():
    """The ccx executable, or None when CalculiX is not installed."""
    return shutil.which("ccx")


def _quadratic(vertices, tets):
    """(nodes, tets10, edge_node): nodes = vertices + one midpoint per mesh edge; edge_node maps a
    sorted vertex pair to its midpoint node."""
    pairs = np.sort(np.concatenate([tets[:, list(e)] for e in _C3D10_EDGES]), axis=1)
    unique, inverse = np.unique(pairs, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    mids = 0.5 * (vertices[unique[:, 0]] + vertices[unique[:, 1]])
    nodes = np.concatenate([vertices, mids])
    mid_of_tet = (len(vertices) + inverse).reshape(len(_C3D10_EDGES), -1).T
    edge_node = {(int(a), int(b)): len(vertices) + k for k, (a, b) in enumerate(unique)}
    return nodes, np.concatenate([tets, mid_of_tet], axis=1), edge_node


def _write_inp(path, nodes, tets10, fixed_nodes, loads):
    with open(path, "w") as f:
        f.write("*NODE\n")
        for i, p in enumerate(nodes):
            f.write("%d,%.12g,%.12g,%.12g\n" % (i + 1, p[0], p[1], p[2]))
        f.write("*ELEMENT,TYPE=C3D10,ELSET=EALL\n")
        for i, t in enumerate(tets10):
            f.write("%d,%s\n" % (i + 1, ",".join(str(int(n) + 1) for n in t)))
        f.write("*NSET,NSET=FIXED\n")
        for n in fixed_nodes:
            f.write("%d\n" % (n + 1))
        f.write("*MATERIAL,NAME=STEEL\n*ELASTIC\n%g,%g\n" % (YOUNG, POISSON))
        f.write("*SOLID SECTION,ELSET=EALL,MATERIAL=STEEL\n")
        f.write("*STEP\n*STATIC\n*BOUNDARY\nFIXED,1,3\n*CLOAD\n")
        for n, force in loads:
            for k in range(3):
                if force[k] != 0:
                    f.write("%d,%d,%.12g\n" % (n + 1, k + 1, force[k]))
        f.write("*NODE FILE\nU\n*EL FILE\nS\n*END STEP\n")


def _read_frd(path, count):
    """{'DISP': #count x 3, 'STRESS': #count x 6} from the .frd's nodal result blocks (short
    format: ' -1', node I10, values E12.5)."""
    out, block = {}, None
    with open(path) as f:
        for line in f:
            if line.startswith(" -4"):
                block = line.split()[1]
                ncomp = 3 if block == "DISP" else 6
                out[block] = np.full((count, ncomp), np.nan)
            elif line.startswith(" -1") and block in ("DISP", "STRESS"):
                node = int(line[3:13]) - 1
                values = [float(line[13 + 12 * k:25 + 12 * k]) for k in range(out[block].shape[1])]
                if node < count:
                    out[block][node] = values
            elif line.startswith(" -3"):
                block = None
    return out


def von_mises(s):
    """Von Mises stress of #N x 6 stresses (xx, yy, zz, xy, yz, zx), as ccx orders them."""
    sxx, syy, szz, sxy, syz, szx = s.T
    return np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2)
                   + 3 * (sxy ** 2 + syz ** 2 + szx ** 2))


def solve(mesh, fixed_tags, load_tags, force):
    """Clamps the boundary triangles tagged fixed_tags, spreads the total `force` (3 N) uniformly
    over those tagged load_tags, and returns (displacement #V x 3 mm, von Mises #V MPa) at the
    linear mesh's vertices. Raises RuntimeError when ccx is missing or fails."""
    exe = ccx_path()
    if exe is None:
        raise RuntimeError("CalculiX (ccx) is not installed")
    vertices = np.asarray(mesh["vertices"], dtype=np.float64)
    tets = np.asarray(mesh["tets"], dtype=np.int64)
    tris = np.asarray(mesh["triangles"], dtype=np.int64)
    tags = np.asarray(mesh["triangle_tags"])
    nodes, tets10, edge_node = _quadratic(vertices, tets)

    def face_nodes(tri):
        mids = [edge_node[tuple(sorted((int(t[a]), int(t[b]))))] for t in tri for a, b in _TRI6_EDGES]
        return np.array(mids, dtype=np.int64).reshape(-1, 3)

    fixed_tri = tris[np.isin(tags, fixed_tags)]
    load_tri = tris[np.isin(tags, load_tags)]
    if len(fixed_tri) == 0 or len(load_tri) == 0:
        raise RuntimeError("the mesh has no triangle on the fixed or the loaded faces")
    fixed = np.unique(np.concatenate([fixed_tri.ravel(), face_nodes(fixed_tri).ravel()]))
    p = vertices[load_tri]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    traction = np.asarray(force, dtype=np.float64) / area.sum()
    nodal = {}
    for mids, a in zip(face_nodes(load_tri), area):
        for n in mids:
            nodal[int(n)] = nodal.get(int(n), 0.0) + a / 3
    loads = [(n, traction * w) for n, w in sorted(nodal.items())]

    with tempfile.TemporaryDirectory() as tmp:
        _write_inp(os.path.join(tmp, "job.inp"), nodes, tets10, fixed, loads)
        run = subprocess.run([exe, "job"], cwd=tmp, capture_output=True, text=True,
                             env=dict(os.environ, OMP_NUM_THREADS="1"))
        frd = os.path.join(tmp, "job.frd")
        if run.returncode != 0 or not os.path.exists(frd):
            tail = (run.stdout + run.stderr).strip().splitlines()[-3:]
            raise RuntimeError("ccx failed (exit %d): %s" % (run.returncode, " / ".join(tail)))
        res = _read_frd(frd, len(vertices))
    if "DISP" not in res or "STRESS" not in res:
        raise RuntimeError("ccx wrote no displacement or stress")
    u, s = res["DISP"], res["STRESS"]
    if not (np.isfinite(u).all() and np.isfinite(s).all()):
        raise RuntimeError("ccx left vertices without results")
    return u, von_mises(s)
