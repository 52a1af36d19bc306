"""Shared fixtures. The tests run as ctests (tests.cmake) with PYTHONPATH at the build tree's
package; run by hand:
    PYTHONPATH=build/release/bindings/python /usr/bin/python3 -m pytest bindings/python/tests
"""
import os
import pathlib
import sys

import pytest

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parents[2]
sys.path.insert(0, str(HERE))  # box_host

import cadinterp  # noqa: E402
import box_host  # noqa: E402

print(f"cadinterp tests: {sys.executable} (Python {sys.version.split()[0]}), "
      f"cadinterp {cadinterp.__version__} from {cadinterp.__file__}", file=sys.stderr)


@pytest.fixture(scope="session")
def cases():
    """conformance/cases (CADINTERP_CASES overrides)."""
    return pathlib.Path(os.environ.get("CADINTERP_CASES", REPO / "conformance" / "cases"))


@pytest.fixture(scope="session")
def box_asset(tmp_path_factory):
    """(path, report, host) of the box host's asset, built once per test process."""
    path = tmp_path_factory.mktemp("box") / "box.cadi"
    host = box_host.BoxHost()
    report = cadinterp.build(host, path, geometry_tolerance=1e-3, field_tolerance=1e-3,
                             threads=2)
    return path, report, host


@pytest.fixture(scope="session")
def every_evaluation():
    """every_evaluation(asset, x): a call of each evaluation of x, for error-path tests."""
    def calls(asset, x):
        return [lambda: asset.eval(x), lambda: asset.grad(x), lambda: asset.vjp(x),
                lambda: asset.eval_properties(x), lambda: asset.eval_many([x])]
    return calls
