"""The paper's method against the compliant zoom, impact by impact, on the paper's case.

Runs the paper's case once with the nonsmooth model (its trajectory does not depend on E),
extracts the impact table with E = 2.1e9 Pa (as printed in the paper) and 2.1e11 Pa (steel), and
re-simulates the largest impacts with compliant contacts (``analysis.add_zoom_forces``). Prints,
for the ``--top`` largest impacts by impulse, the kind, the paper-method F_max and the zoom's
F_max, and the ratio by kind.

    python benchmarks/zoom_vs_paper.py [--t-end 0.3] [--top 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import analysis
import simcore
from analysis.impacts import KIND, RACE
from analysis.zoom import add_zoom_forces

KIND_NAME = {v: k for k, v in KIND.items()}
RACE_NAME = {v: k for k, v in RACE.items()}


def table(run_ds, youngs_modulus: float, top: int, kind: str | None = None):
    """Impact table of ``run_ds`` evaluated with ``youngs_modulus``, its ``top`` largest impacts
    (of ``kind``, if given) zoomed."""
    ds = run_ds.copy()
    ds.attrs = dict(run_ds.attrs, **{"model.youngs_modulus": youngs_modulus})
    imp = analysis.extract_impacts(ds)
    if kind is not None:
        imp = imp.isel(impact=np.flatnonzero(imp["kind"].values == KIND[kind]))
    # the table of the ``top`` largest by impulse, all of them zoomed
    imp = imp.isel(impact=np.sort(np.argsort(-imp["impulse"].values, kind="stable")[:top]))
    return add_zoom_forces(
        ds, imp, zoom_top=top, overrides=[f"model.youngs_modulus={youngs_modulus}"],
        adaptive=False)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--t-end", type=float, default=0.3, help="length of the run [s]")
    p.add_argument("--top", type=int, default=5, help="largest impacts (by impulse) zoomed")
    args = p.parse_args(argv)
    run_ds = simcore.run(simcore.load_config(overrides=[f"solver.t_end={args.t_end}"]))
    ratios: dict[str, list[float]] = {}
    for kind in (None, "simple"):
        print(f"\nlargest {args.top} {kind or 'impacts'} by impulse")
        rows = {}
        for E in (2.1e9, 2.1e11):
            start = time.perf_counter()
            rows[E] = table(run_ds, E, args.top, kind)
            print(f"E = {E:.3g} Pa: impact table and {args.top} zooms in "
                  f"{time.perf_counter() - start:.1f} s")
        print_rows(rows[2.1e9], rows[2.1e11], args.top, ratios)
    print("paper's method / zoom, by kind (both E):")
    for kind, r in sorted(ratios.items()):
        print(f"  {kind}: {len(r)} values, {min(r):.2f} to {max(r):.2f}")
    return 0


def print_rows(t9, t11, top, ratios):
    """Markdown rows of the ``top`` largest impacts of the two tables; collects the ratios."""
    order = np.argsort(-t9["impulse"].values, kind="stable")[:top]
    print("| time [s] | ball | race | kind | impulse [N s] | v_pre [m/s] | E = 2.1e9: paper's "
          "method [N] | zoom [N] | E = 2.1e11: paper's method [N] | zoom [N] |")
    print("|---|---|---|---|---|---|---|---|---|---|")

    def fmt(x):
        return "–" if not np.isfinite(x) else f"{x:,.0f}"

    for i in order:
        kind = KIND_NAME[int(t9["kind"].values[i])]
        cells = []
        for t in (t9, t11):
            f, z = float(t["F_max"].values[i]), float(t["F_max_zoom"].values[i])
            cells += [fmt(f), fmt(z)]
            if np.isfinite(f) and np.isfinite(z) and z > 0:
                ratios.setdefault(kind, []).append(f / z)
        print(f"| {float(t9['time'].values[i]):.4f} | {int(t9['ball'].values[i])} | "
              f"{RACE_NAME[int(t9['race'].values[i])]} | {kind} | "
              f"{float(t9['impulse'].values[i]):.3f} | {float(t9['v_pre'].values[i]):.3f} | "
              + " | ".join(cells) + " |")


if __name__ == "__main__":
    raise SystemExit(main())
