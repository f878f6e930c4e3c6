"""Steady statistics of the compliant twin over many crank revolutions, against fixed steps:
where a single trajectory does not converge with the step (a chaotic point, docs/study.md,
"The twin's convergence"), whether the distribution of each revolution's largest force does.

    python benchmarks/twin_statistics.py                     the reference point, 800
                                                             revolutions: the twin and fixed
                                                             2, 1 and 0.5 us
    python benchmarks/twin_statistics.py --revolutions 100 --fixed 1e-6 --tols
    python benchmarks/twin_statistics.py --shifts 0 1e-9     each run also from a start with
                                                             ball 0 moved by 1 nm, the two
                                                             runs' revolutions pooled
    python benchmarks/twin_statistics.py --save DIR          also each run's table, DIR/*.npz
    python benchmarks/twin_statistics.py --load DIR [DIR]    print saved tables again (pooled
                                                             by run)

Each run is the study's twin of the point (:func:`simcore.study.plan.twin_config`: steel,
adaptive steps of at most the output step, rho_inf 0.5) for 1 + ``--revolutions`` crank
revolutions, with adaptive steps at each of ``--tols`` or fixed steps of each of ``--fixed``
(same rho_inf), from each start of ``--shifts`` (ball 0 moved along the pitch circle by
that many metres: at a chaotic point an independent trajectory, whose revolutions are pooled
with the others'). Of each steady revolution (after the first, the study's ``analysis.settle``)
it takes the largest ``F_N`` per race (:func:`analysis.summary.revolution_peak_table`) and
prints per race the mean, median and 90th percentile of those, the mean's 95 % interval from
20 batch means, the lag-1 autocorrelation of the revolutions (near 0: independent samples,
the intervals hold), the change of the mean from the first half of the revolutions to the
second (a steady state), and the differences of mean and median against the last run listed
(the finest fixed step) with their 95 % bootstrap intervals (scipy.stats.bootstrap). Then,
per run and window length n of ``--windows`` (windows of n consecutive revolutions of one
start, as a study with ``study.revolutions`` = n reads them), the spread of the window's
median (the summary's ``peak_force_rev_median``: its standard deviation and 5-95 % range over
the windows) and the mean of the window's largest force (``peak_force``) over the median of
all revolutions.
"""

from __future__ import annotations

import argparse
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from _common import point_twin
from scipy import stats

import simcore
from analysis.summary import RACES, SteadyWindow, race_forces, revolution_peak_table

REFERENCE = (4e-4, 0.01, 50.0, 0.9)  # clearance [m], mu, omega0 [rad/s], e_N
BATCHES = 20


def run_table(twin: dict, label: str, tol: float | None, dt: float | None,
              shift: float = 0.0) -> dict:
    """Run the twin with adaptive steps at ``tol`` [m] or fixed steps ``dt`` [s], ball 0 moved
    by ``shift`` [m] at the start: its steps, integration time [s], whether every step
    converged, and its per-revolution table."""
    from analysis.episodes import compliant_forces
    from analysis.impacts import race_codes

    twin = dict(twin, model=dict(twin["model"], ball0_shift=shift),
                solver=dict(twin["solver"]))
    solver = twin["solver"]
    # the run's dataset holds every output step (1e-4 s) of the whole window; a step that
    # fails (after its retries) is flagged and counted, not the end of hours of runs
    solver.update(max_memory_gb=16.0, on_nonconvergence="warn")
    if tol is not None:
        solver.update(adaptive=True, adaptive_tol=tol)
    else:
        solver.update(adaptive=False, dt=dt, on_unresolved_dt="warn")
    ds = simcore.run(twin)
    force = compliant_forces(ds)
    races = race_codes(ds, force.shape[0]).astype(np.int64)
    time = np.asarray(ds["time"].values, dtype=float)
    per_race = race_forces(force, races)
    sample_race = np.broadcast_to(np.arange(len(RACES))[:, None], per_race.shape)
    window = SteadyWindow.of_run(ds, 1.0)
    table = revolution_peak_table(window, np.broadcast_to(time, per_race.shape).ravel(),
                                  sample_race.ravel(), per_race.ravel())
    table = table[:int(np.floor(window.revolutions + 0.01))]  # whole revolutions only
    steps = (int(ds.attrs["n_steps_accepted"]) if tol is not None
             else int(round(solver["t_end"] / dt)))
    return {"label": label, "steps": steps, "time_s": float(ds.attrs["wall_time_s"]),
            "converged": int(np.min(ds["converged"].values)),
            "flagged": int(np.count_nonzero(ds["converged"].values == 0)),
            "retried": int(ds.attrs["n_retried_steps"]), "table": table}


def batch_interval(x: np.ndarray) -> float:
    """Half-width of the 95 % interval of the mean of ``x`` from :data:`BATCHES` batch means."""
    means = np.array([b.mean() for b in np.array_split(x, BATCHES)])
    return float(stats.t.ppf(0.975, BATCHES - 1) * means.std(ddof=1) / np.sqrt(BATCHES))


def lag1(x: np.ndarray) -> float:
    """Lag-1 autocorrelation of ``x``."""
    d = x - x.mean()
    return float(np.sum(d[1:] * d[:-1]) / np.sum(d * d))


def difference_interval(x: np.ndarray, y: np.ndarray, statistic) -> tuple[float, float, float]:
    """statistic(x) - statistic(y) and its 95 % bootstrap interval (independent samples)."""
    res = stats.bootstrap((x, y), lambda a, b, axis: statistic(a, axis=axis)
                          - statistic(b, axis=axis), n_resamples=4000,
                          random_state=np.random.default_rng(0))
    ci = res.confidence_interval
    return float(statistic(x) - statistic(y)), float(ci.low), float(ci.high)


def _order(label: str) -> tuple:
    """Adaptive runs first (coarsest tolerance first), then fixed ones, the finest last."""
    value = float(label.split("=")[1].split()[0])
    return (label.startswith("fixed"), -value)


def pooled(runs: list[dict]) -> list[dict]:
    """The runs of each label (one per start) as one: their revolutions, steps and times
    summed, converged only if all are; ordered by :func:`_order`."""
    out: dict[str, dict] = {}
    for run in runs:
        have = out.get(run["label"])
        if have is None:
            out[run["label"]] = dict(run, starts=1, parts=[run["table"]])
            continue
        have.update(steps=have["steps"] + run["steps"], time_s=have["time_s"] + run["time_s"],
                    converged=min(have["converged"], run["converged"]),
                    flagged=have.get("flagged", 0) + run.get("flagged", 0),
                    retried=have.get("retried", 0) + run.get("retried", 0),
                    table=np.concatenate([have["table"], run["table"]]),
                    starts=have["starts"] + 1, parts=[*have["parts"], run["table"]])
    return [out[k] for k in sorted(out, key=_order)]


def window_numbers(parts: list[np.ndarray], race: int, n: int) -> tuple:
    """Over the windows of ``n`` consecutive revolutions of each part (one start's table):
    the standard deviation of the window's median over the median of all revolutions, its
    5 and 95 % percentiles [N], and the mean of the window's largest over that median, and the
    number of windows."""
    blocks = [p[:(p.shape[0] // n) * n, race].reshape(-1, n) for p in parts]
    blocks = np.concatenate(blocks)
    overall = np.median(np.concatenate([p[:, race] for p in parts]))
    medians = np.median(blocks, axis=1)
    return (float(medians.std(ddof=1) / overall), *np.percentile(medians, [5, 95]),
            float(blocks.max(axis=1).mean() / overall), blocks.shape[0])


def report(runs: list[dict], windows=()) -> None:
    """Print the statistics of each run and its differences against the last run."""
    ref = runs[-1]
    for run in runs:
        print(f"{run['label']}: {run['steps']:,} steps, {run['time_s']:.1f} s, "
              f"{run['table'].shape[0]} revolutions from {run['starts']} start(s)"
              + (f", {run['retried']} output rows with a retried step" if "retried" in run
                 else "")
              + ("" if run["converged"] else
                 f", FLAGGED: {run.get('flagged', 0)} rows with a step that did not converge"))
        for r, race in enumerate(RACES):
            x = run["table"][:, r]
            half = x.size // 2
            drift = x[half:].mean() / x[:half].mean() - 1.0
            line = (f"  {race:6s} mean {x.mean():7.1f} ± {batch_interval(x):5.1f} N, median "
                    f"{np.median(x):7.1f} N, p90 {np.percentile(x, 90):7.1f} N, std "
                    f"{x.std(ddof=1):6.1f} N, lag-1 {lag1(x):+.3f}, halves {100 * drift:+.2f} %")
            if run is not ref:
                y = ref["table"][:, r]
                for name, statistic in (("mean", np.mean), ("median", np.median)):
                    d, lo, hi = difference_interval(x, y, statistic)
                    s = statistic(y)
                    line += (f"; {name} {100 * d / s:+.2f} % [{100 * lo / s:+.2f}, "
                             f"{100 * hi / s:+.2f}]")
            print(line, flush=True)
        for n in windows:
            if run["table"].shape[0] < 2 * n:
                continue
            for r, race in enumerate(RACES):
                spread, p5, p95, largest, count = window_numbers(run["parts"], r, n)
                print(f"  {race:6s} windows of {n} revolutions ({count}): median spread "
                      f"{100 * spread:.1f} % ({p5:.0f}-{p95:.0f} N), largest "
                      f"{100 * (largest - 1):+.0f} % over the median")
    if len(runs) > 1:
        print(f"(differences against {ref['label']}, 95 % bootstrap intervals)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--point", default=",".join(str(x) for x in REFERENCE),
                        metavar="C,MU,OMEGA0,E_N")
    parser.add_argument("--revolutions", type=float, default=800.0,
                        help="steady revolutions after the first")
    parser.add_argument("--tols", type=float, nargs="*", default=None,
                        help="adaptive tolerances [m] (default: the twin's; none: no "
                             "adaptive run)")
    parser.add_argument("--fixed", type=float, nargs="*", default=[2e-6, 1e-6, 5e-7],
                        help="fixed steps [s], the last the reference")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                        help="other settings of the study, e.g. model.cage_damping=100")
    parser.add_argument("--shifts", type=float, nargs="+", default=[0.0],
                        help="starts: ball 0 moved along the pitch circle by each [m]")
    parser.add_argument("--windows", type=int, nargs="*", default=[3, 10, 30, 100],
                        help="window lengths [revolutions] of the window statistics")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--save", type=Path, default=None, help="folder for the tables")
    parser.add_argument("--load", type=Path, nargs="+", default=None,
                        help="print the tables saved in these folders instead of running")
    args = parser.parse_args()
    if args.load:
        runs = []
        for path in sorted(p for folder in args.load for p in folder.glob("*.npz")):
            with np.load(path) as f:
                runs.append({k: (f[k].item() if f[k].ndim == 0 else f[k]) for k in f.files})
        report(pooled(runs), args.windows)
        return
    point = tuple(float(x) for x in args.point.split(","))
    twin = point_twin(point, args.revolutions, args.set)
    tols = [twin["solver"]["adaptive_tol"]] if args.tols is None else args.tols
    jobs = [(label, tol, dt, shift) for shift in args.shifts for label, tol, dt in
            [(f"adaptive tol={t:.3g} m", t, None) for t in tols]
            + [(f"fixed dt={dt:.3g} s", None, dt) for dt in args.fixed]]
    print(f"point clearance={point[0]} m, mu={point[1]}, omega0={point[2]} rad/s, "
          f"e_N={point[3]}; {args.revolutions:g} steady revolutions", flush=True)
    with ProcessPoolExecutor(max_workers=max(1, min(args.jobs, len(jobs)))) as pool:
        runs = list(pool.map(run_table, [twin] * len(jobs), *zip(*jobs, strict=True)))
    if args.save:
        args.save.mkdir(parents=True, exist_ok=True)
        for (label, _, _, shift), run in zip(jobs, runs, strict=True):
            np.savez(args.save / f"{label.replace(' ', '_')}_shift={shift:g}.npz", **run)
    report(pooled(runs), args.windows)


if __name__ == "__main__":
    main()
