"""Error paths of the runtime: each gives a clear Python exception (the class of its C status,
or TypeError/ValueError for malformed arguments), never a crash. The builder's are in
test_builder.py."""
import numpy as np
import pytest

import cadinterp


@pytest.fixture
def asset(cases):
    with cadinterp.Asset(cases / "valid" / "k2_cubic" / "asset.cadi") as a:
        yield a


def test_classes_follow_the_status_table():
    seen = set()
    for code in range(1, 18):
        cls = cadinterp._errors.error_class(code)
        assert issubclass(cls, cadinterp.Error) and cls.status == code
        assert cls.status_name.startswith("CADINTERP_E_") and cls not in seen
        seen.add(cls)
        # The names agree with the C library's own text of the status.
        assert cadinterp.status_string(code) != "unknown status"
    assert issubclass(cadinterp.OutsideDomainError, ValueError)
    assert issubclass(cadinterp.InvalidArgumentError, ValueError)
    assert issubclass(cadinterp.IoError, OSError)
    assert issubclass(cadinterp.ChecksumError, cadinterp.FormatError)
    assert cadinterp._errors.error_class(999) is cadinterp.Error


def test_bad_files(tmp_path, cases):
    with pytest.raises(cadinterp.IoError, match="missing.cadi") as e:
        cadinterp.Asset(tmp_path / "missing.cadi")
    assert e.value.status == 3 and e.value.status_name == "CADINTERP_E_IO"
    with pytest.raises(cadinterp.IoError):
        cadinterp.Asset(tmp_path)  # a directory
    junk = tmp_path / "junk.cadi"
    junk.write_bytes(b"this is not an asset, just some text" * 10)
    with pytest.raises(cadinterp.BadMagicError):
        cadinterp.Asset(junk)
    for data in (b"", b"not an asset", bytes(1000)):
        with pytest.raises(cadinterp.FormatError):
            cadinterp.Asset(data)
    whole = (cases / "valid" / "k2_linear" / "asset.cadi").read_bytes()
    with pytest.raises(cadinterp.TruncatedError):
        cadinterp.Asset(whole[:-1])
    for wrong in (None, 42, 3.5, ["a.cadi"]):
        with pytest.raises(TypeError, match="path"):
            cadinterp.Asset(wrong)


def test_damaged_element_at_eval(cases):
    with cadinterp.Asset(cases / "invalid" / "blob_checksum" / "asset.cadi") as a:
        with pytest.raises(cadinterp.ChecksumError):
            a.eval([0.0])
        with pytest.raises(cadinterp.ChecksumError):
            a.eval_many([[0.0]])


def test_x_outside_the_box(asset, every_evaluation):
    for x in ([1.5, 0.5], [0.5, -0.1], [np.nan, 0.5], [0.5, np.inf]):
        for call in every_evaluation(asset, x) + [lambda: asset.error_estimate(x),
                                                  lambda: asset.locate(x)]:
            with pytest.raises(cadinterp.OutsideDomainError, match=r"x\[\d\] \((bend|twist)\)"):
                call()


@pytest.mark.parametrize("x,error", [
    ([0.5], ValueError), ([0.5, 0.5, 0.5], ValueError), ([[0.5, 0.5]], ValueError),
    (0.5, ValueError), ([], ValueError),
    ("ab", TypeError), (None, TypeError), ([0.5, "a"], TypeError), ([0.5, None], TypeError),
    (np.array([0.5 + 1j, 0.5]), TypeError), ({"bend": 0.5}, TypeError),
])
def test_malformed_x(asset, x, error):
    with pytest.raises(error, match="x must"):
        asset.eval(x)
    with pytest.raises(error, match="x must"):
        asset.grad(x)


def test_malformed_X(asset):
    with pytest.raises(ValueError, match="X must"):
        asset.eval_many(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="X must"):
        asset.eval_many(np.zeros(4))  # K=2: a 1-D X is not N points
    with pytest.raises(TypeError, match="X must"):
        asset.eval_many([["a", "b"]])
    with pytest.raises(ValueError, match="errors"):
        asset.eval_many(np.zeros((1, 2)), errors="ignore")
    with pytest.raises(ValueError, match="threads"):
        asset.eval_many(np.zeros((1, 2)), threads=-1)
    assert asset.eval_many(np.zeros((0, 2))) == []


def test_bad_fields(asset):
    with pytest.raises(cadinterp.NotFoundError, match="no field named 'pressure'.*temperature"):
        asset.eval([0.5, 0.5], "pressure")
    with pytest.raises(cadinterp.InvalidArgumentError, match="field index 2"):
        asset.eval([0.5, 0.5], [2])
    with pytest.raises(cadinterp.InvalidArgumentError):
        asset.grad([0.5, 0.5], [-1])
    with pytest.raises(TypeError, match="field"):
        asset.eval([0.5, 0.5], [0.5])
    with pytest.raises(TypeError, match="field"):
        asset.eval([0.5, 0.5], [True])


def test_bad_adjoints(asset):
    x = [0.5, 0.5]
    m = asset.eval(x)
    with pytest.raises(ValueError, match="dvertices must hold"):
        asset.vjp(x, dvertices=np.ones((len(m.vertices) - 1, 3)))
    with pytest.raises(ValueError, match="stress"):
        asset.vjp(x, dfields={"stress": np.ones(len(m.tets) + 1)})
    with pytest.raises(TypeError, match="dict"):
        asset.vjp(x, dfields=[np.ones(len(m.tets))])
    with pytest.raises(TypeError):
        asset.vjp(x, dvertices="abc")
    with pytest.raises(cadinterp.NotFoundError):
        asset.vjp(x, dfields={"nope": np.ones(3)})


def test_bad_property_arguments(asset):
    x = [0.5, 0.5]
    with pytest.raises(ValueError, match="direction"):
        asset.eval_properties(x, direction=(1, 0))
    with pytest.raises(cadinterp.InvalidArgumentError):
        asset.eval_properties(x, density=float("nan"))
    with pytest.raises(cadinterp.InvalidArgumentError):
        asset.eval_properties(x, direction=(np.inf, 0, 0))
    with pytest.raises(cadinterp.InvalidArgumentError):
        asset.element_mesh_size(asset.element_count)


def test_closed_asset(asset, every_evaluation):
    asset.close()
    for call in every_evaluation(asset, [0.5, 0.5]) + [lambda: asset.locate([0.5, 0.5])]:
        with pytest.raises(ValueError, match="closed"):
            call()
    assert [p.name for p in asset.parameters] == ["bend", "twist"]  # the description stays
