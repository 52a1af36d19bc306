#!/usr/bin/python3
"""Sweeps one parameter of an asset and plots mass, the maximum of a field and the builder's
error estimate against it, into a PNG (matplotlib, Agg backend: no display needed).

    PYTHONPATH=build/release/bindings/python /usr/bin/python3 bindings/python/examples/sweep.py \\
        [ASSET] [--parameter NAME] [--at NAME=VALUE ...] [--field NAME] [--points N] [-o OUT.png]

ASSET defaults to the wrench scripts/demo.sh builds (build/demo/wrench.cadi). The other
parameters sit at the middle of their range unless --at sets them. The field defaults to
von_mises when the asset has it, else its first field; a field of several components is
reduced to its magnitude per row. Points where the model is infeasible are left as gaps.
"""
import argparse
import pathlib
import sys

import numpy as np

import cadinterp

REPO = pathlib.Path(__file__).resolve().parents[3]
DEFAULT_ASSET = REPO / "build" / "demo" / "wrench.cadi"


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("asset", nargs="?", default=str(DEFAULT_ASSET),
                   help=f"the asset (default: {DEFAULT_ASSET.relative_to(REPO)})")
    p.add_argument("--parameter", default=None, help="the parameter to sweep (default: the first)")
    p.add_argument("--at", action="append", default=[], metavar="NAME=VALUE",
                   help="value of another parameter (default: the middle of its range)")
    p.add_argument("--field", default=None, help="the field whose maximum is plotted")
    p.add_argument("--points", type=int, default=41, help="points along the sweep (default 41)")
    p.add_argument("--density", type=float, default=1.0, help="density for the mass (default 1)")
    p.add_argument("--threads", type=int, default=2, help="evaluation threads (default 2)")
    p.add_argument("-o", "--output", default="sweep.png", help="the PNG (default sweep.png)")
    return p.parse_args(argv)


def sweep_points(asset, parameter, at, n):
    """(index of the swept parameter, N by K points)."""
    names = [p.name for p in asset.parameters]
    if parameter is None:
        d = 0
    elif parameter in names:
        d = names.index(parameter)
    else:
        raise SystemExit(f"sweep: no parameter '{parameter}' (the asset has: {', '.join(names)})")
    x = asset.bounds.mean(axis=1)
    for item in at:
        name, _, value = item.partition("=")
        if name not in names:
            raise SystemExit(f"sweep: --at {item}: no parameter '{name}'")
        x[names.index(name)] = float(value)
    X = np.tile(x, (n, 1))
    X[:, d] = np.linspace(*asset.bounds[d], n)
    return d, X


def field_of(asset, name):
    names = [f.name for f in asset.fields]
    if not names:
        raise SystemExit("sweep: the asset has no fields")
    if name is None:
        return "von_mises" if "von_mises" in names else names[0]
    if name not in names:
        raise SystemExit(f"sweep: no field '{name}' (the asset has: {', '.join(names)})")
    return name


def evaluate(asset, X, field, density, threads):
    """Mass, field maximum and error estimate per point (NaN where x is infeasible)."""
    mass, peak, error = (np.full(len(X), np.nan) for _ in range(3))
    meshes = asset.eval_many(X, [field], threads=threads, errors="none")
    for i, (x, m) in enumerate(zip(X, meshes)):
        if m is None:
            continue
        error[i] = asset.error_estimate(x)
        values = m.fields[field]
        peak[i] = (np.linalg.norm(values, axis=1) if values.ndim == 2 else values).max()
        mass[i] = asset.eval_properties(x, density=density)["mass"]
    return mass, peak, error


def plot(path, title, xlabel, t, series):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(series), 1, sharex=True, figsize=(7, 2.4 * len(series)))
    for ax, (label, values) in zip(axes, series):
        ax.plot(t, values, marker="o", markersize=3)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].set_title(title)
    axes[-1].set_xlabel(xlabel)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv):
    args = parse_args(argv)
    with cadinterp.Asset(args.asset) as asset:
        d, X = sweep_points(asset, args.parameter, args.at, args.points)
        field = field_of(asset, args.field)
        mass, peak, error = evaluate(asset, X, field, args.density, args.threads)
        p = asset.parameters[d]
        unit = {f.name: f.unit for f in asset.fields}[field]
        fixed = ", ".join(f"{q.name} = {X[0, i]:g}" for i, q in enumerate(asset.parameters)
                          if i != d)
    print(f"{'x':>10} {'mass':>12} {'max ' + field:>16} {'error est.':>11}")
    for row in zip(X[:, d], mass, peak, error):
        print(f"{row[0]:10.4g} {row[1]:12.6g} {row[2]:16.6g} {row[3]:11.3g}")
    plot(args.output, f"{pathlib.Path(args.asset).name}: sweep of {p.name}" +
         (f" ({fixed})" if fixed else ""), f"{p.name} [{p.unit}]" if p.unit else p.name, X[:, d],
         [(f"mass (density {args.density:g})", mass),
          (f"max {field}" + (f" [{unit}]" if unit else ""), peak),
          ("error estimate\n(of bbox diagonal)", error)])
    print(f"sweep: {np.isfinite(mass).sum()} of {len(X)} points feasible; wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
