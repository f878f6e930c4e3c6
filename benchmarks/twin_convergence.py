"""Convergence of the compliant twin in its step: steady peak force per race against the
number of steps per Hertz contact time (``analysis.zoom_steps_per_contact``, the twin's N).

    python benchmarks/twin_convergence.py                 N = 10, 20, 40, 80 on two points
    python benchmarks/twin_convergence.py --n 20 40       other N

For each point (steel, constant drive, the default study's settings; clearance, mu, omega0,
e_N given below) the twin of :func:`simcore.study.plan.twin_config` runs 1 + ``--revolutions``
crank revolutions; printed per N: the twin's step, the largest ``F_N`` per race after the
first revolution (the steady window of the study, ``analysis.settle`` = 1) and its change
against the finest N, the median over revolutions of each revolution's largest force, and the
run's integration time; then, for the same N, the compliant zooms of the nonsmooth run
(``analysis.zoom_top`` largest impacts, the same key sets their step): their ``F_max_zoom``
against the finest N.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import simcore
from simcore.study import plan

POINTS = (  # (clearance [m], mu, omega0 [rad/s], e_N): the reference and a small clearance
    (4e-4, 0.01, 50.0, 0.9),
    (2e-5, 0.01, 100.0, 0.7),
)


def steady_peaks(ds, settle: float = 1.0):
    """(largest F_N per race, median over revolutions of each revolution's largest per race)
    after ``settle`` crank revolutions [N]."""
    angle = np.asarray(ds["crank_angle"].values, dtype=float)
    turns = (angle - angle[0]) / (2.0 * math.pi)
    force = np.asarray(ds["F_N"].values, dtype=float)
    race = np.asarray(ds["race"].values).astype(str)
    rev = np.floor(turns).astype(int)
    out_max, out_med = [], []
    for name in ("inner", "outer"):
        f = force[:, race == name].max(axis=1)
        steady = turns >= settle
        out_max.append(float(f[steady].max()))
        per_rev = [f[(rev == r) & steady].max() for r in np.unique(rev[steady])
                   if np.any((rev == r) & steady)]
        out_med.append(float(np.median(per_rev)))
    return out_max, out_med


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[10, 20, 40, 80])
    parser.add_argument("--revolutions", type=float, default=2.0)
    args = parser.parse_args()
    for clearance, mu, omega0, e_N in POINTS:
        cfg = simcore.load_config("config/config.yaml", overrides=[
            f"study.revolutions={args.revolutions}", f"sweep.clearance=[{clearance}]",
            f"sweep.mu=[{mu}]", f"sweep.omega0=[{omega0}]", f"sweep.e_N=[{e_N}]"])
        results = {}
        for n in sorted(args.n):
            cfg["analysis"]["zoom_steps_per_contact"] = n
            twin = [r for r in plan.plan_runs(cfg) if r.model == "compliant"][0]
            ds = simcore.run(twin.config)
            results[n] = (twin.config["solver"]["dt"], *steady_peaks(ds), ds.attrs["wall_time_s"])
        ns = [r for r in plan.plan_runs(cfg) if r.model == "nonsmooth"][0]
        run = simcore.run(ns.config)
        zooms = {}
        for n in sorted(args.n):
            from analysis import extract_impacts
            from analysis.zoom import add_zoom_forces

            table = extract_impacts(run, zero_tol=cfg["analysis"]["zero_tol"])
            table = add_zoom_forces(run, table, zoom_top=cfg["analysis"]["zoom_top"],
                                    steps_per_contact=n)
            f = np.asarray(table["F_max_zoom"].values, dtype=float)
            zooms[n] = f[np.isfinite(f)]
        finest = results[max(results)]
        print(f"point clearance={clearance} m, mu={mu}, omega0={omega0} rad/s, e_N={e_N}, "
              f"E={cfg['model']['youngs_modulus']:.3g} Pa:")
        for n, (dt, peak, median, wall) in results.items():
            change = [p / f - 1.0 for p, f in zip(peak, finest[1], strict=True)]
            print(f"  N={n:4d} dt={dt:.3e} s  peak inner/outer {peak[0]:9.1f} {peak[1]:9.1f} N "
                  f"({100 * change[0]:+.2f} %, {100 * change[1]:+.2f} % vs N={max(results)}); "
                  f"median per rev {median[0]:9.1f} {median[1]:9.1f} N; {wall:.1f} s", flush=True)
        best = zooms[max(zooms)]
        for n, f in zooms.items():
            if f.size == best.size and f.size:
                change = np.max(np.abs(f / best - 1.0))
                print(f"  zooms N={n:4d}: F_max_zoom " + " ".join(f"{x:.0f}" for x in f)
                      + f" N (largest change {100 * change:.2f} % vs N={max(zooms)})")


if __name__ == "__main__":
    main()
