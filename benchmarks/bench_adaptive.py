"""Adaptive against fixed compliant steps on steady points of the study, with steel.

For each point (constant drive, E = 2.1e11 Pa, ``--revolutions`` crank revolutions) it runs
the compliant model with fixed steps of decreasing size (``--fixed``, a sequence halving
towards convergence) and with adaptive steps (``solver.adaptive``, largest step ``--dt-max``,
``--tols`` local error tolerances [m]), all on the same output grid (``--output-dt``), and
prints for each run the largest normal force per race (inner, outer) in each revolution after
the first, its largest relative change against the finest fixed step, the steps taken (and
rejected) and the wall and CPU time of the integration (one thread; the machine may be
shared, so times are noisy and steps are the stable measure of cost).

Points:

- ``reference``: the study's steady reference point, clearance 4e-4 m, mu 0.01, omega0 50
  rad/s, e_N 0.9;
- ``small``: clearance 2e-5 m, mu 0.01, omega0 100 rad/s, e_N 0.7.

Usage: python benchmarks/bench_adaptive.py [--points reference small] [--revolutions 4]
       [--fixed 2e-6 1e-6 5e-7 2.5e-7] [--dt-max 1e-5] [--tols 1e-9] [--output-dt 1e-5]
       [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

POINTS = {
    "reference": {"model.clearance": 4e-4, "model.mu": 0.01, "model.omega0": 50.0,
                  "model.e_N": 0.9},
    "small": {"model.clearance": 2e-5, "model.mu": 0.01, "model.omega0": 100.0,
              "model.e_N": 0.7},
}


def point_config(name: str):
    from simcore.config import load_config

    overrides = [f"{k}={v}" for k, v in POINTS[name].items()]
    overrides += ["model.youngs_modulus=2.1e11", "model.drive=constant",
                  "model.contact_model=compliant"]
    return load_config(overrides=overrides)


def revolution_peaks(traj, omega0: float, n_balls: int, revolutions: int) -> np.ndarray:
    """Largest F_N per revolution (rows: revolutions 2 .. ``revolutions``) and race (columns:
    inner, outer) [N]. A row's interval belongs to the revolution its end time falls in."""
    rev = np.floor(traj.time[1:] * omega0 / (2.0 * math.pi) * (1.0 - 1e-12)).astype(int)
    F = traj.F_N[1:]
    peaks = np.zeros((revolutions - 1, 2))
    for r in range(1, revolutions):
        rows = rev == r
        peaks[r - 1, 0] = F[rows, :n_balls].max()
        peaks[r - 1, 1] = F[rows, n_balls:].max()
    return peaks


def run(name: str, revolutions: int, dt: float, output_dt: float, adaptive: bool,
        tol: float) -> dict:
    from simcore.model import SolverSettings
    from simcore.model.mechanism import crank_slider

    cfg = point_config(name)
    model, _ = crank_slider(cfg["model"])
    omega0 = cfg["model"]["omega0"]
    t_end = revolutions * 2.0 * math.pi / omega0
    every = max(1, round(output_dt / dt))
    settings = SolverSettings(dt, t_end, contact_model="compliant", output_every=every,
                              adaptive=adaptive, adaptive_tol=tol, on_nonconvergence="warn",
                              chunk=100 * every)
    cpu = time.process_time()
    traj = model.simulate(settings)
    cpu = time.process_time() - cpu
    rec = traj.extras.get("adaptive")
    steps = rec["n_steps_accepted"] if rec else settings.n_steps
    return {
        "point": name, "adaptive": adaptive, "dt": dt, "tol": tol if adaptive else None,
        "peaks": revolution_peaks(traj, omega0, cfg["model"]["n_balls"], revolutions).tolist(),
        "steps": int(steps), "rejected": int(rec["n_steps_rejected"]) if rec else 0,
        "dt_smallest": rec["dt_smallest_s"] if rec else dt,
        "newton": traj.extras["newton_steps"], "chord": traj.extras["chord_iterates"],
        "wall_s": traj.wall_time_s, "cpu_s": cpu, "flagged": int((traj.converged == 0).sum()),
    }


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--points", nargs="+", default=["reference", "small"])
    p.add_argument("--revolutions", type=int, default=4)
    p.add_argument("--fixed", nargs="+", type=float, default=[2e-6, 1e-6, 5e-7, 2.5e-7])
    p.add_argument("--dt-max", type=float, default=1e-5)
    p.add_argument("--tols", nargs="+", type=float, default=[1e-9])
    p.add_argument("--output-dt", type=float, default=1e-5)
    p.add_argument("--json", default=None)
    args = p.parse_args()

    import numba

    numba.set_num_threads(1)
    from simcore.model import SolverSettings
    from simcore.model.mechanism import crank_slider

    warm = crank_slider(point_config("reference")["model"])[0]
    for adaptive in (False, True):  # compile or load the kernels before timing
        warm.simulate(SolverSettings(1e-6, 1e-5, contact_model="compliant", adaptive=adaptive))
    results = []
    for name in args.points:
        fixed = [run(name, args.revolutions, dt, args.output_dt, False, 0.0)
                 for dt in sorted(args.fixed, reverse=True)]
        adaptive = [run(name, args.revolutions, args.dt_max, args.output_dt, True, tol)
                    for tol in args.tols]
        ref = np.array(fixed[-1]["peaks"])
        print(f"\n{name}: {POINTS[name]}, steel, constant drive, {args.revolutions} "
              f"revolutions; largest F_N per race in revolutions 2..{args.revolutions} "
              f"(inner | outer) [N]; change: largest relative difference to the finest fixed "
              f"step (dt = {fixed[-1]['dt']:g} s)")
        for r in fixed + adaptive:
            peaks = np.array(r["peaks"])
            r["change"] = float(np.max(np.abs(peaks - ref) / ref))
            label = (f"adaptive tol {r['tol']:g} m, dt <= {r['dt']:g}" if r["adaptive"]
                     else f"fixed dt {r['dt']:g} s")
            inner = " ".join(f"{x:8.1f}" for x in peaks[:, 0])
            outer = " ".join(f"{x:8.1f}" for x in peaks[:, 1])
            extra = (f", {r['rejected']} rejected, smallest {r['dt_smallest']:.3g} s"
                     if r["adaptive"] else "") + f", {r['newton']:,} Newton steps"
            print(f"  {label:<36} {inner} | {outer}   change {r['change']:.2e}; "
                  f"{r['steps']:,} steps{extra}; wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s; "
                  f"flagged {r['flagged']}")
        results += fixed + adaptive
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    t0 = time.perf_counter()
    main()
    print(f"\n(total {time.perf_counter() - t0:.0f} s)")
