"""Tests of the FreeCAD host (README.md, "Tests"): meshes, IDs across the topology change,
references, CalculiX against beam theory, infeasible points, and a tiny build when the cadinterp
Python package is importable."""
import os

import numpy as np
import pytest

import accuracy
import bracket_model
import calculix
import freecad_host
import naming

THIN = np.array([50.0, 4.0])    # the hole in the thin plate
THIN_2 = np.array([54.0, 3.0])  # elsewhere in the thin plate: same topology
ACROSS = np.array([40.0, 4.0])  # the hole across the step: the step face split in two
ROOT = np.array([35.0, 3.0])    # the hole in the root block


@pytest.fixture(scope="module")
def host():
    return freecad_host.BracketHost(mesh_size=3.0)


def _check_mesh(mesh, volume):
    v, t, f = mesh["vertices"], mesh["tets"], mesh["triangles"]
    a, b, c, d = (v[t[:, k]] for k in range(4))
    det = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)
    assert (det > 0).all()
    # Closed and consistently oriented: every directed boundary edge exactly once, its reverse too.
    directed = {(int(e[0]), int(e[1])) for tri in f for e in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0]))}
    assert len(directed) == 3 * len(f)
    assert all((q, p) in directed for p, q in directed)
    # Outward: the divergence theorem over the triangles gives the tets' volume.
    p = v[f]
    enclosed = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
    assert enclosed == pytest.approx(det.sum() / 6, rel=1e-9)
    assert det.sum() / 6 == pytest.approx(volume, rel=0.01)
    assert len(mesh["triangle_tags"]) == len(f)


@pytest.mark.parametrize("x, faces", [(THIN, 9), (ACROSS, 10), (ROOT, 9)])
def test_meshes_valid_with_expected_faces(host, x, faces):
    mesh = host.regenerate(x)
    solid = host._last[1]
    _check_mesh(mesh, solid.Volume)
    assert len(solid.Faces) == faces
    assert len(np.unique(mesh["triangle_tags"])) == faces


def _points(host, x):
    return {tuple(i): np.array(p) for i, p in host.references(x)["points"]}


def test_ids_stable_where_topology_is_unchanged(host):
    a, b = _points(host, THIN), _points(host, THIN_2)
    assert a.keys() == b.keys()
    # The root's corner does not move with the hole.
    label = "V[plate.xmin+root.xmin|plate.ymin+root.ymin|root.zmax]"
    assert label in host._last[2].vertexes
    (key,) = [k for k in a if k[0] == 0 and k[1] == naming.entity_id(label)]
    assert np.allclose(a[key], [0, 0, bracket_model.ROOT_THICKNESS])
    assert np.allclose(a[key], b[key])


def test_ids_change_where_topology_changes(host):
    a, b = _points(host, THIN), _points(host, ACROSS)
    names_b = host._last[2]
    common = a.keys() & b.keys()
    # Far from the step, nothing changed: the tip face's corners and edge points keep their IDs.
    tip = {k for k, p in a.items() if p[0] > bracket_model.LENGTH - 1e-9}
    assert len(tip) == 4 + 4 * 3 and tip <= common
    # Across the step, the step face is split in two and the hole's rim meets it at four new
    # vertices; the step face's edges along the thin plate's top are new entities.
    assert names_b.faces.count("root.xmax#0") == 1 and names_b.faces.count("root.xmax#1") == 1
    assert sum(l.startswith("V[hole.wall|") and "root.xmax" in l for l in names_b.vertexes) == 4
    step_edge = naming.entity_id("E[plate.zmax|root.xmax]")
    assert any(k[:2] == (1, step_edge) for k in a)
    assert not any(k[:2] == (1, step_edge) for k in b)
    assert len(a.keys() - common) > 0 and len(b.keys() - common) > 0


@pytest.mark.parametrize("x", [THIN, ACROSS, ROOT])
def test_paths_and_regions(host, x):
    mesh = host.regenerate(x)
    refs = host.references(x, mesh)
    points = {tuple(i): np.array(p) for i, p in refs["points"]}
    vertices = {tuple(np.round(v, 9)) for v in mesh["vertices"]}
    # Every control point is a mesh vertex (the mapper anchors only those).
    assert all(tuple(np.round(p, 9)) in vertices for p in points.values())
    for a, b, poly in refs["paths"]:
        assert np.allclose(poly[0], points[tuple(a)]) and np.allclose(poly[-1], points[tuple(b)])
        # Interior polyline points are vertices of the boundary mesh.
        assert all(tuple(np.round(p, 9)) in vertices for p in poly[1:-1])
    regions = {name: (kind, tags) for name, kind, tags in refs["regions"]}
    assert regions["root"][0] == "fixed" and regions["tip"][0] == "force"
    v, f, tags = mesh["vertices"], mesh["triangles"], mesh["triangle_tags"]
    assert np.allclose(v[f[np.isin(tags, regions["root"][1])]][..., 0], 0)
    assert np.allclose(v[f[np.isin(tags, regions["tip"][1])]][..., 0], bracket_model.LENGTH)


# CADINTERP_REQUIRE_ALL=1 (set by scripts/test.sh) turns the skips below into failures, so that
# CI cannot pass without CalculiX or the Python package.
REQUIRE_ALL = os.environ.get("CADINTERP_REQUIRE_ALL") == "1"


@pytest.mark.skipif(calculix.ccx_path() is None and not REQUIRE_ALL,
                    reason="CalculiX (ccx) not installed")
def test_ccx_against_beam_theory(host):
    mesh = host.regenerate(THIN)
    fields = {f["name"]: f for f in host.simulate(THIN, mesh)}
    vm, u = fields["von_mises"]["values"], fields["displacement"]["values"]
    v = mesh["vertices"]
    assert np.isfinite(vm).all() and np.isfinite(u).all()
    assert fields["von_mises"]["unit"] == "MPa" and u.shape == (len(v), 3)
    assert np.abs(u[v[:, 0] < 1e-9]).max() == 0  # clamped
    L, W, F = bracket_model.LENGTH, bracket_model.WIDTH, freecad_host.FORCE_N
    T, S, T2 = bracket_model.THICKNESS, bracket_model.STEP, bracket_model.ROOT_THICKNESS
    # Bending stress on the root block's top face, away from the clamp and the step:
    # sigma = 6 F (L - x) / (W T2^2) (Euler-Bernoulli).
    top = (np.abs(v[:, 2] - T2) < 1e-9) & (np.abs(v[:, 0] - 20) < 5) & (np.abs(v[:, 1] - W / 2) < 6)
    assert top.sum() >= 3
    beam = 6 * F * (L - v[top, 0]) / (W * T2 ** 2)
    assert np.abs(vm[top] / beam - 1).max() < 0.05
    # Tip deflection of the stepped beam without the hole, F/(3E) ((L^3 - (L-S)^3)/I2 +
    # (L-S)^3/I1); the hole, shear and the step's corner make the plate softer.
    w = -u[v[:, 0] > L - 1e-9, 2].mean()
    i1, i2 = W * T ** 3 / 12, W * T2 ** 3 / 12
    closed = F / (3 * calculix.YOUNG) * ((L ** 3 - (L - S) ** 3) / i2 + (L - S) ** 3 / i1)
    assert 1.0 < w / closed < 1.2


def test_near_tangency_is_infeasible(host):
    with pytest.raises(bracket_model.InfeasibleError, match="tangency"):
        host.regenerate(np.array([44.1, 4.0]))


def test_end_to_end_build(tmp_path):
    """A 3 x 3 grid build (4 elements). The two elements at hole_x >= 46 hold the hole in the
    thin plate at every sample, so they must be built and match FreeCAD between samples."""
    if REQUIRE_ALL:
        import cadinterp
    else:
        cadinterp = pytest.importorskip("cadinterp")
    coarse = freecad_host.BracketHost(mesh_size=4.0, levels=0)
    asset_path = str(tmp_path / "bracket.cadi")
    report = cadinterp.build(coarse, asset_path, max_samples=9, max_depth=1,
                             store=str(tmp_path / "bracket.sqlite"))
    assert report.samples == 9 and report.elements == 4 and report.infeasible_points == 0
    asset = cadinterp.Asset(asset_path)
    assert [(f.name, f.unit) for f in asset.fields] == [("von_mises", "MPa"), ("displacement", "mm")]
    assert {r.name: r.kind for r in asset.regions} == {"root": "fixed", "tip": "force"}
    x = np.array([52.0, 3.5])
    m = asset.eval(x)
    true = coarse.regenerate(x)
    truth = {f["name"]: f["values"] for f in coarse.simulate(x, true)}
    assert accuracy.relative_hausdorff(dict(vertices=m.vertices, triangles=m.triangles), true) < 1e-2
    # Displacement is smooth: the blend of two samples matches FreeCAD's own solution closely.
    # Von Mises on 4 mm tets differs between two meshes of one shape by a fifth of its range
    # at the stress peaks, so only its bulk is held to a bound.
    u_err = accuracy.field_errors(m.vertices, m.fields["displacement"], true, truth["displacement"])
    vm_err = accuracy.field_errors(m.vertices, m.fields["von_mises"], true, truth["von_mises"])
    assert u_err.max() < 0.02
    assert np.median(vm_err) < 0.02 and np.percentile(vm_err, 99) < 0.3
