"""Adaptive against fixed-step compliant zooms of a study run's impact table.

One nonsmooth run per point (steel, constant drive, the study's run length: one start-up
revolution and ``--revolutions`` steady ones); its impact table's zoomed rows
(:func:`analysis.zoom.zoom_rows`, ``analysis.zoom_top`` 5 and the start-up's largest) are
zoomed with fixed steps (t_Hertz / N for each ``--fixed`` N) and with adaptive steps (largest
step t_Hertz / :data:`analysis.zoom.ADAPTIVE_STEPS_PER_CONTACT`). Prints, per point,
F_max_zoom and contact_time_zoom of every row and, per variant, the steps and the CPU time of
all the zooms (median of ``--repeat``, variants alternated) and the largest and median
relative difference of F_max_zoom from the finest fixed variant. ``--full-window``: every zoom
runs its whole window (no early stop on the impacts' balls). ``--set KEY=VALUE``: other
settings of the runs and their zooms (e.g. ``solver.onset_speed=last_open``).

    python benchmarks/zoom_adaptive.py [--fixed 20 40 80] [--revolutions 3] [--full-window]
                                       [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import analysis
import simcore
import simcore.study.zoom
from analysis.summary import SteadyWindow
from analysis.zoom import ADAPTIVE_STEPS_PER_CONTACT, add_zoom_forces, zoom_rows

POINTS = {
    "reference (4e-4 m, mu 0.01, 50 rad/s, e_N 0.9)": [
        "model.clearance=4e-4", "model.mu=0.01", "model.omega0=50", "model.e_N=0.9"],
    "small clearance (2e-5 m, mu 0.01, 100 rad/s, e_N 0.7)": [
        "model.clearance=2e-5", "model.mu=0.01", "model.omega0=100", "model.e_N=0.7"],
}


def study_run(point, revolutions, overrides=()):
    """The nonsmooth run of a study point (with the configuration's ``overrides``), its impact
    table and the end of its start-up."""
    cfg = simcore.load_config(overrides=["model.drive=constant", "model.youngs_modulus=2.1e11",
                                         *point, *overrides])
    t_end = (1.0 + revolutions) * 2 * np.pi / abs(cfg["model"]["omega0"])
    cfg["solver"]["t_end"] = float(np.ceil(t_end / cfg["solver"]["dt"]) * cfg["solver"]["dt"])
    run = simcore.run(cfg)
    table = analysis.extract_impacts(run)
    return run, table, SteadyWindow.of_run(run, 1.0).settle_time


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--fixed", type=int, nargs="+", default=[20, 40, 80],
                   help="steps per Hertz contact time of the fixed-step zooms")
    p.add_argument("--revolutions", type=float, default=3.0, help="steady revolutions")
    p.add_argument("--top", type=int, default=5, help="analysis.zoom_top")
    p.add_argument("--repeat", type=int, default=5, help="timings per variant (median)")
    p.add_argument("--full-window", action="store_true",
                   help="zooms run their whole window (no stop once the impacts' balls are "
                        "free, until_released=False)")
    p.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                   help="other settings of the runs and their zooms")
    args = p.parse_args(argv)
    if args.full_window:
        whole = simcore.study.zoom.zoom_trajectory
        simcore.study.zoom.zoom_trajectory = (
            lambda *a, **kw: whole(*a, **dict(kw, until_released=False)))
    variants = [("fixed", n) for n in args.fixed] + [("adaptive", ADAPTIVE_STEPS_PER_CONTACT)]
    for name, point in POINTS.items():
        run, table, settle = study_run(point, args.revolutions, args.set)
        rows = zoom_rows(table, args.top, settle)
        print(f"\n## {name}: {table.sizes['impact']} impacts, {rows.size} zoomed rows")
        for adaptive in (False, True):  # (compiled kernels loaded before the timings)
            add_zoom_forces(run, table, zoom_top=1, settle_time=settle, adaptive=adaptive,
                            loaded="zoom")
        results = {}
        cpus = {key: [] for key in variants}
        for _ in range(args.repeat):  # (variants alternated: a shared machine's load drifts)
            for kind, n in variants:
                start = time.process_time()
                # (loaded balls zoomed all the same: this compares the zoom's steps)
                out = add_zoom_forces(run, table, zoom_top=args.top, steps_per_contact=n,
                                      settle_time=settle, adaptive=kind == "adaptive",
                                      loaded="zoom")
                cpus[kind, n].append(time.process_time() - start)
                results[kind, n] = (out.isel(impact=rows), float(np.median(cpus[kind, n])))
        ref_key = ("fixed", max(args.fixed))
        ref = results[ref_key][0]["F_max_zoom"].values
        print("| variant | steps | CPU [s], median | F_max_zoom [N] | contact_time_zoom [us] | "
              f"max / median rel. diff. from fixed N={ref_key[1]} |")
        print("|---|---|---|---|---|---|")
        for key, (out, cpu) in results.items():
            F = out["F_max_zoom"].values
            rel = np.abs(F / ref - 1.0)
            forces = " ".join(f"{f:,.1f}" for f in F)
            times = " ".join(f"{t * 1e6:.2f}" for t in out["contact_time_zoom"].values)
            print(f"| {key[0]} N={key[1]} | {out.attrs['n_zoom_steps']:,} | {cpu:.2f} | "
                  f"{forces} | {times} | {np.nanmax(rel):.2e} / {np.nanmedian(rel):.2e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
