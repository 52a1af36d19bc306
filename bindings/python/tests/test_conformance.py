"""Every conformance case (conformance/cases/INDEX.txt) through Python, against the C runner: the
runner (cadinterp-conformance --dump) writes the raw bytes the C ABI returned, and every array
the binding returns must equal them bit for bit; every refusal must be the exception class of
the status the case expects."""
import os
import pathlib
import subprocess

import numpy as np
import pytest

import cadinterp

REPO = pathlib.Path(__file__).resolve().parents[3]
CASES = pathlib.Path(os.environ.get("CADINTERP_CASES", REPO / "conformance" / "cases"))


def index():
    rows = []
    for line in (CASES / "INDEX.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            case, expectation, _ = (c.strip() for c in line.split("|", 2))
            rows.append((case, expectation))
    return rows



def parse_expected(case_dir):
    """(open status name, [(x, status name)]) from expected.txt."""
    open_status, points, x = None, [], None
    for line in (case_dir / "expected.txt").read_text().splitlines():
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if words[0] == "open":
            open_status = words[1]
        elif words[0] == "point":
            x = np.array([float.fromhex(w) for w in words[1:]])
        elif words[0] == "status":
            points.append((x, words[1]))
    return open_status, points


def error_class(status_name):
    for cls in vars(cadinterp).values():
        if isinstance(cls, type) and getattr(cls, "status_name", None) == status_name:
            return cls
    raise AssertionError(f"cadinterp has no class for {status_name}")


@pytest.fixture(scope="module")
def dump(tmp_path_factory):
    runner = os.environ.get("CADINTERP_CONFORMANCE_RUNNER")
    if not runner:
        pytest.fail("CADINTERP_CONFORMANCE_RUNNER (the C runner's path) is not set")
    out = tmp_path_factory.mktemp("c-dump")
    run = subprocess.run([runner, str(CASES), "--dump", str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    return out


def test_index_lists_every_case():
    listed = {case for case, _ in index()}
    on_disk = {f"{g}/{d.name}" for g in ("valid", "invalid") for d in (CASES / g).iterdir()}
    assert listed == on_disk and len(listed) >= 28


def same_bytes(got, dump_dir, name):
    want = (dump_dir / name).read_bytes()
    assert got.tobytes() == want, f"{name}: the binding's bytes differ from the C runner's"


@pytest.mark.parametrize("case,expectation", index(), ids=[c for c, _ in index()])
def test_case(case, expectation, dump):
    case_dir, dump_dir = CASES / case, dump / case
    open_status, points = parse_expected(case_dir)
    assert (dump_dir / "open").read_text() == str(
        0 if open_status == "CADINTERP_OK" else error_class(open_status).status)
    if open_status != "CADINTERP_OK":
        assert expectation == f"open {open_status}"
        cls = error_class(open_status)
        with pytest.raises(cls):
            cadinterp.Asset(case_dir / "asset.cadi")
        with pytest.raises(cls):  # the same bytes from memory
            cadinterp.Asset((case_dir / "asset.cadi").read_bytes())
        return
    with cadinterp.Asset(case_dir / "asset.cadi") as asset:
        fields = [0] if asset.fields else []
        assert points, "a case that opens has points"
        for n, (x, status) in enumerate(points):
            p = f"p{n}_"
            if status != "CADINTERP_OK":
                assert (dump_dir / (p + "status")).read_text() == str(error_class(status).status)
                with pytest.raises(error_class(status)):
                    asset.eval(x, fields)
                with pytest.raises(error_class(status)):
                    asset.grad(x, fields)
                continue
            assert (dump_dir / (p + "status")).read_text() == "0"
            m = asset.eval(x, fields)
            assert str(m.element) == (dump_dir / (p + "element")).read_text()
            same_bytes(m.vertices, dump_dir, p + "positions")
            same_bytes(m.tets, dump_dir, p + "tets")
            same_bytes(m.triangles, dump_dir, p + "triangles")
            same_bytes(m.triangle_tags, dump_dir, p + "tags")
            g = asset.grad(x, fields)
            same_bytes(g.vertices, dump_dir, p + "grad_positions")
            same_bytes(g.dvertices, dump_dir, p + "dpositions")
            if fields:
                name = asset.fields[0].name
                same_bytes(m.fields[name], dump_dir, p + "field0")
                same_bytes(g.dfields[name], dump_dir, p + "dfield0")
