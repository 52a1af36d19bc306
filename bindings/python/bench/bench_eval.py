#!/usr/bin/python3
"""Call overhead of eval from Python against C, for one point and for a batch of 1,000 points:
the C ABI straight (bench_eval_c, one workspace reused), this package (pybind11: eval, a loop of
eval, eval_many), and ctypes over the same library (the alternative binding, measured here, not
shipped). Medians of timeit repeats; every evaluation is warm (each element decoded once first).

    PYTHONPATH=build/release/bindings/python /usr/bin/python3 bindings/python/bench/bench_eval.py \\
        ASSET [ASSET ...] [--fields all|none] [--build build/release]

Prints one markdown table row per asset and way of calling.
"""
import argparse
import ctypes
import pathlib
import statistics
import subprocess
import tempfile
import timeit

import numpy as np

import cadinterp

REPO = pathlib.Path(__file__).resolve().parents[3]


class CMesh(ctypes.Structure):  # cadinterp_mesh, cadinterp.h
    _fields_ = [("element", ctypes.c_int), ("vertex_count", ctypes.c_uint32),
                ("tet_count", ctypes.c_uint32), ("triangle_count", ctypes.c_uint32),
                ("tets", ctypes.POINTER(ctypes.c_uint32)),
                ("triangles", ctypes.POINTER(ctypes.c_uint32)),
                ("triangle_tags", ctypes.POINTER(ctypes.c_int32)),
                ("positions", ctypes.POINTER(ctypes.c_float)),
                ("fields", ctypes.POINTER(ctypes.POINTER(ctypes.c_float)))]


class CtypesEval:
    """eval through ctypes, returning zero-copy numpy views of positions and fields. Views with
    no lifetime guard: the next call overwrites them (what a thin ctypes binding gives)."""

    def __init__(self, lib, path, fields):
        self.lib = ctypes.CDLL(str(lib))
        self.lib.cadinterp_open.argtypes = [ctypes.c_char_p, ctypes.c_void_p]
        self.lib.cadinterp_workspace_create.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        self.lib.cadinterp_eval.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_double),
                                            ctypes.POINTER(ctypes.c_int), ctypes.c_int,
                                            ctypes.POINTER(CMesh)]
        self.asset, self.ws = ctypes.c_void_p(), ctypes.c_void_p()
        assert self.lib.cadinterp_open(str(path).encode(), ctypes.byref(self.asset)) == 0
        assert self.lib.cadinterp_workspace_create(self.asset, ctypes.byref(self.ws)) == 0
        self.fields = (ctypes.c_int * max(1, len(fields)))(*fields)
        self.nf = len(fields)
        self.mesh = CMesh()

    def __call__(self, x):
        x = np.ascontiguousarray(x, dtype=np.float64)
        s = self.lib.cadinterp_eval(self.ws, x.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                                    self.fields, self.nf, ctypes.byref(self.mesh))
        if s != 0:
            raise RuntimeError(f"status {s}")
        m = self.mesh
        v = np.ctypeslib.as_array(m.positions, shape=(m.vertex_count, 3))
        return v, [np.ctypeslib.as_array(m.fields[i], shape=(m.vertex_count,))
                   for i in range(self.nf)]


def median_seconds(fn, number, repeat):
    return statistics.median(timeit.repeat(fn, number=number, repeat=repeat)) / number


def bench(path, fields_mode, build, n=1000, repeat=31):
    a = cadinterp.Asset(path)
    X = np.random.default_rng(0).uniform(a.bounds[:, 0], a.bounds[:, 1], (n, a.parameter_count))
    feasible = [x for x in X if a.locate(x)[1]]
    X = np.array(feasible)
    fields = list(range(len(a.fields))) if fields_mode == "all" else []
    x0 = X[0]
    a.eval_many(X, fields)  # warm: every element decoded once
    m = a.eval(x0, fields)
    inner = max(20, int(2e-3 / max(1e-7, timeit.timeit(lambda: a.eval(x0, fields), number=20) / 20)))
    rows = {}
    with tempfile.NamedTemporaryFile(suffix=".bin") as f:
        X.tofile(f.name)
        out = subprocess.run([str(build / "bindings/python/bench_eval_c"), str(path), f.name,
                              fields_mode, str(repeat), str(inner)],
                             capture_output=True, text=True, check=True).stdout
    c = dict(item.split("=") for item in out.split())
    rows["C ABI (bench_eval_c)"] = (float(c["one_us"]), float(c["batch_ms"]))

    def loop_dropping():  # each result freed before the next call: its workspace is reused
        for x in X:
            a.eval(x, fields)

    rows["pybind11: Asset.eval, results dropped"] = (
        1e6 * median_seconds(lambda: a.eval(x0, fields), inner, repeat),
        1e3 * median_seconds(loop_dropping, 1, repeat))
    # Every result kept: each holds its own workspace (fresh memory per result, as a copy would).
    rows["pybind11: [Asset.eval(x) for x in X], kept"] = (
        None, 1e3 * median_seconds(lambda: [a.eval(x, fields) for x in X], 1, repeat))
    rows["pybind11: Asset.eval_many(X), kept"] = (
        None, 1e3 * median_seconds(lambda: a.eval_many(X, fields), 1, repeat))
    ct = CtypesEval(build / "src/runtime/libcadinterp.so", path, fields)
    rows["ctypes (unguarded views)"] = (
        1e6 * median_seconds(lambda: ct(x0), inner, repeat),
        1e3 * median_seconds(lambda: [ct(x) for x in X], 1, repeat))
    name = f"{pathlib.Path(path).parent.name}/{pathlib.Path(path).name}"
    size = f"{len(m.vertices)} V, {len(m.tets)} T, fields: {fields_mode}"
    c_one, c_batch = rows["C ABI (bench_eval_c)"]
    for how, (one, batch) in rows.items():
        one_text = "" if one is None else f"{one:.2f} ({one - c_one:+.2f})"
        print(f"| {name} ({size}) | {how} | {one_text} | {batch:.2f} ({batch / c_batch:.2f}x) "
              f"| {len(X)} |")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("assets", nargs="+")
    p.add_argument("--fields", choices=["all", "none"], default="all")
    p.add_argument("--build", default=str(REPO / "build" / "release"))
    args = p.parse_args()
    print("| asset | called by | one point, us (vs C) | 1,000 points, ms (vs C) | points |")
    print("|---|---|---|---|---|")
    for path in args.assets:
        bench(path, args.fields, pathlib.Path(args.build))


if __name__ == "__main__":
    main()
