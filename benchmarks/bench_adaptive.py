"""Adaptive against fixed compliant steps on steady points of the study, with steel.

Each point runs the compliant model (constant drive, E = 2.1e11 Pa) for ``--revolutions``
crank revolutions; the number compared is the largest normal force per race (inner, outer) in
each revolution after the first, the study's steady statistic.

These runs are chaotic: a change of 1e-15 m in the initial position of one ball changes those
peaks by up to some ten per cent (printed as "chaos"), far more than any step size does. So a
whole run cannot show that the peaks converge with the step. The script therefore measures in
two ways:

1. Through each peak (``windows``): the fixed-step run at ``--dt-ref`` is restarted from its
   state (positions, velocities, the contacts' onset speeds) ``--lead`` seconds before the
   peak's output interval and integrated for ``--window`` seconds with fixed steps of
   decreasing size (``--fixed``) and with adaptive steps (``--tols``); printed: the largest
   force of the peak's race in the window for each, and its relative change against the finest
   fixed step. This is where the fixed step converges and where the adaptive step must agree
   with it.
2. Whole runs (``runs``): the fixed step at ``--dt-ref`` (and at ``--whole-fixed``) and the
   adaptive steps over all the revolutions: the per-revolution peaks, the steps taken (and
   rejected), Newton steps, wall and CPU time of the integration, and the same fixed run with
   the initial state moved by 1e-15 m (the chaos the peaks carry whatever the steps).

All runs share the output grid ``--output-dt`` (per interval the largest force is kept, so no
peak is lost). Times are on one thread of a possibly shared machine: steps are the stable
measure of cost.

Points: ``reference`` (the study's reference point: clearance 4e-4 m, mu 0.01, omega0 50
rad/s, e_N 0.9) and ``small`` (clearance 2e-5 m, mu 0.01, omega0 100 rad/s, e_N 0.7).

``--onset-speed`` is the fixed steps' ``solver.onset_speed`` (docs/compliant.md, "Onset speed
v_pre"; adaptive steps take the crossing's either way).

Usage: python benchmarks/bench_adaptive.py [--points reference small] [--revolutions 4]
       [--dt-ref 5e-7] [--fixed 2e-6 1e-6 5e-7 2.5e-7 1.25e-7] [--tols 1e-9]
       [--whole-fixed 1e-6 2.5e-7]
       [--dt-max 1e-5] [--output-dt 1e-5] [--window 1e-3] [--lead 5e-4] [--json FILE]
       [--onset-speed crossing | last_open]
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
RACES = ("inner", "outer")


def point_config(name: str):
    """The validated configuration of a point (compliant, steel, constant drive)."""
    from simcore.config import load_config

    overrides = [f"{k}={v}" for k, v in POINTS[name].items()]
    overrides += ["model.youngs_modulus=2.1e11", "model.drive=constant",
                  "model.contact_model=compliant"]
    return load_config(overrides=overrides)


def revolution_of_rows(time_: np.ndarray, omega0: float, t0: float = 0.0) -> np.ndarray:
    """Crank revolution (0 = the first) of each output interval, by its end time."""
    return np.floor((time_[1:] - t0) * omega0 / (2.0 * math.pi) * (1.0 - 1e-12)).astype(int)


def revolution_peaks(traj, omega0: float, n_balls: int, revolutions: int):
    """Largest F_N [N] per revolution after the first (rows) and race (columns), and the
    output row of each."""
    rev = revolution_of_rows(traj.time, omega0)
    peaks = np.zeros((revolutions - 1, 2))
    rows = np.zeros((revolutions - 1, 2), dtype=int)
    for r in range(1, revolutions):
        sel = np.flatnonzero(rev == r)
        for c, cols in enumerate((slice(0, n_balls), slice(n_balls, 2 * n_balls))):
            f = traj.F_N[1:][sel, cols].max(axis=1)
            i = int(np.argmax(f))
            peaks[r - 1, c] = f[i]
            rows[r - 1, c] = sel[i] + 1
    return peaks, rows


#: the fixed steps' solver.onset_speed (--onset-speed)
ONSET_SPEED = {"fixed": "crossing"}


def simulate(model, dt, t_end, output_dt, adaptive, tol, dt_max, q0=None, v0=None, t0=0.0,
             v_pre0=None):
    """One compliant run; returns (trajectory, CPU seconds, steps, rejected steps)."""
    from simcore.model import SolverSettings

    step = dt_max if adaptive else dt
    every = max(1, round(output_dt / step))
    settings = SolverSettings(step, t_end, contact_model="compliant", output_every=every,
                              adaptive=adaptive, adaptive_tol=tol or 1e-9,
                              on_nonconvergence="warn", chunk=max(500, 10 * every),
                              onset_speed=ONSET_SPEED["fixed"])
    cpu = time.process_time()
    traj = model.simulate(settings, q0=q0, v0=v0, t0=t0, v_pre0=v_pre0)
    cpu = time.process_time() - cpu
    rec = traj.extras.get("adaptive")
    steps = rec["n_steps_accepted"] if rec else settings.n_steps
    return traj, cpu, int(steps), int(rec["n_steps_rejected"]) if rec else 0


def restart_state(model, args, row):
    """The fixed-step run's state at output row ``row``: (q, v, onset speeds, time), from the
    same run stopped there (the same steps, so the same numbers)."""
    traj = simulate(model, args.dt_ref, row * args.output_dt, args.output_dt, False, None,
                    args.dt_max)[0]
    return (traj.q[-1].copy(), traj.v[-1].copy(),
            traj.extras["compliant_state"].v_pre.copy(), float(traj.time[-1]))


def windows(name, model, ref, rows, args) -> list[dict]:
    """Restarts through each per-revolution peak (see the module docstring): from the fixed
    run's state (positions, velocities and the contacts' onset speeds) before the peak."""
    n_balls = (ref.F_N.shape[1]) // 2
    lead_rows = round(args.lead / args.output_dt)
    starts = {}
    out = []
    for r in range(rows.shape[0]):
        for c in range(2):
            start = max(rows[r, c] - lead_rows, 1)
            if start not in starts:
                starts[start] = restart_state(model, args, start)
            q0, v0, v_pre0, t0 = starts[start]
            cols = slice(c * n_balls, (c + 1) * n_balls)
            row = {"point": name, "revolution": r + 1, "race": RACES[c], "t0": t0,
                   "runs": []}
            for kind, dt, tol in ([("fixed", dt, None) for dt in args.fixed]
                                  + [("adaptive", None, tol) for tol in args.tols]):
                traj, cpu, steps, rej = simulate(model, dt, args.window, args.output_dt,
                                                 kind == "adaptive", tol, args.dt_max, q0, v0,
                                                 t0, v_pre0)
                row["runs"].append({"kind": kind, "dt": dt, "tol": tol, "steps": steps,
                                    "rejected": rej, "peak": float(traj.F_N[1:, cols].max()),
                                    "flagged": int((traj.converged == 0).sum())})
            finest = row["runs"][len(args.fixed) - 1]["peak"]
            for run in row["runs"]:
                run["change"] = abs(run["peak"] - finest) / finest
            out.append(row)
    return out


def print_windows(rows, args) -> None:
    print(f"  through each peak: restart {args.lead * 1e3:g} ms before its interval, "
          f"{args.window * 1e3:g} ms; largest force of its race [N] (change against dt = "
          f"{args.fixed[-1]:g} s), steps; 'not converged': a flagged step (the run goes on "
          "with on_nonconvergence = warn)")
    for row in rows:
        cells = []
        for run in row["runs"]:
            label = f"dt {run['dt']:g}" if run["kind"] == "fixed" else f"tol {run['tol']:g}"
            if run["flagged"]:
                cells.append(f"{label}: not converged")
                continue
            cells.append(f"{label}: {run['peak']:.1f} ({run['change']:.1e}) {run['steps']}")
        print(f"    rev {row['revolution']} {row['race']:<5} t0 = {row['t0']:.5f} s: "
              + "; ".join(cells))


def whole_runs(name, model, cfg, args) -> dict:
    omega0, n_balls = cfg["model"]["omega0"], cfg["model"]["n_balls"]
    t_end = args.revolutions * 2.0 * math.pi / omega0
    res = {}
    ref, cpu, steps, _ = simulate(model, args.dt_ref, t_end, args.output_dt, False, None,
                                  args.dt_max)
    peaks, rows = revolution_peaks(ref, omega0, n_balls, args.revolutions)
    res["fixed"] = {"dt": args.dt_ref, "peaks": peaks.tolist(), "steps": steps,
                    "rejected": 0, "newton": ref.extras["newton_steps"], "cpu_s": cpu,
                    "wall_s": ref.wall_time_s, "flagged": int((ref.converged == 0).sum())}
    q0, v0 = model.initial_state()
    q0[3 * 3] += 1e-15  # the first ball's x
    pert = simulate(model, args.dt_ref, t_end, args.output_dt, False, None, args.dt_max,
                    q0, v0)[0]
    res["chaos"] = {"peaks": revolution_peaks(pert, omega0, n_balls,
                                              args.revolutions)[0].tolist()}
    for dt in args.whole_fixed:
        traj, cpu, steps, _ = simulate(model, dt, t_end, args.output_dt, False, None,
                                       args.dt_max)
        res[f"fixed {dt:g}"] = {
            "dt": dt, "peaks": revolution_peaks(traj, omega0, n_balls,
                                                args.revolutions)[0].tolist(),
            "steps": steps, "rejected": 0, "newton": traj.extras["newton_steps"],
            "cpu_s": cpu, "wall_s": traj.wall_time_s,
            "flagged": int((traj.converged == 0).sum())}
    for tol in args.tols:
        traj, cpu, steps, rej = simulate(model, None, t_end, args.output_dt, True, tol,
                                         args.dt_max)
        rec = traj.extras["adaptive"]
        res[f"adaptive {tol:g}"] = {
            "tol": tol, "dt_max": args.dt_max,
            "peaks": revolution_peaks(traj, omega0, n_balls, args.revolutions)[0].tolist(),
            "steps": steps, "rejected": rej, "newton": traj.extras["newton_steps"],
            "dt_smallest": rec["dt_smallest_s"], "cpu_s": cpu, "wall_s": traj.wall_time_s,
            "flagged": int((traj.converged == 0).sum())}
    return res, ref, rows


def print_runs(res, args) -> None:
    fixed = np.array(res["fixed"]["peaks"])
    print(f"  whole runs, {args.revolutions} revolutions: largest force per revolution "
          "2.. (inner | outer) [N], change against the fixed step")
    for key, r in res.items():
        peaks = np.array(r["peaks"])
        change = float(np.max(np.abs(peaks - fixed) / fixed))
        inner = " ".join(f"{x:7.1f}" for x in peaks[:, 0])
        outer = " ".join(f"{x:7.1f}" for x in peaks[:, 1])
        label = (f"fixed dt {r['dt']:g} s" if key.startswith("fixed") else
                 "fixed, ball moved 1e-15 m" if key == "chaos" else
                 f"adaptive tol {r['tol']:g} m, dt <= {r['dt_max']:g} s")
        cost = ""
        if "steps" in r:
            cost = (f"; {r['steps']:,} steps, {r['rejected']:,} rejected, {r['newton']:,} "
                    f"Newton steps; wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s; "
                    f"flagged {r['flagged']}")
            if "dt_smallest" in r:
                cost += f"; smallest step {r['dt_smallest']:.3g} s"
        print(f"    {label:<36} {inner} | {outer}  change {change:.1e}{cost}")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--points", nargs="+", default=["reference", "small"])
    p.add_argument("--revolutions", type=int, default=4)
    p.add_argument("--dt-ref", type=float, default=5e-7)
    p.add_argument("--fixed", nargs="+", type=float,
                   default=[2e-6, 1e-6, 5e-7, 2.5e-7, 1.25e-7])
    p.add_argument("--tols", nargs="+", type=float, default=[1e-9])
    p.add_argument("--whole-fixed", nargs="*", type=float, default=[],
                   help="more fixed steps for the whole runs (a non-chaotic point converges)")
    p.add_argument("--dt-max", type=float, default=1e-5)
    p.add_argument("--output-dt", type=float, default=1e-5)
    p.add_argument("--window", type=float, default=1e-3)
    p.add_argument("--lead", type=float, default=5e-4)
    p.add_argument("--json", default=None)
    p.add_argument("--onset-speed", choices=["crossing", "last_open"], default="crossing")
    args = p.parse_args()
    ONSET_SPEED["fixed"] = args.onset_speed
    args.fixed = sorted(args.fixed, reverse=True)

    import numba

    numba.set_num_threads(1)
    from simcore.model import SolverSettings
    from simcore.model.mechanism import crank_slider

    warm = crank_slider(point_config("reference")["model"])[0]
    for adaptive in (False, True):  # compile or load the kernels before timing
        warm.simulate(SolverSettings(1e-6, 1e-5, contact_model="compliant", adaptive=adaptive))
    report = {}
    for name in args.points:
        cfg = point_config(name)
        model = crank_slider(cfg["model"])[0]
        print(f"\n{name}: {POINTS[name]}, E = 2.1e11 Pa, constant drive")
        res, ref, rows = whole_runs(name, model, cfg, args)
        print_runs(res, args)
        win = windows(name, model, ref, rows, args)
        print_windows(win, args)
        report[name] = {"runs": res, "windows": win}
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    t0 = time.perf_counter()
    main()
    print(f"\n(total {time.perf_counter() - t0:.0f} s)")
