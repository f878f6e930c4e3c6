"""Energy error of a compliant twin against its error tolerance (docs/compliant.md, "Energy and
the tolerance").

    python benchmarks/energy_tolerance.py                       the grooved point below
    python benchmarks/energy_tolerance.py --set model.cage_damping=0 --set model.mu=0
    python benchmarks/energy_tolerance.py --tols 1e-9 --fixed --t-end 1.0054

The twin of a grid point (:func:`simcore.study.plan.twin_config` of config/config.yaml's study:
steel, constant drive, adaptive steps of at most the nonsmooth step, rho_inf 0.5; default the
point 4e-4 m, mu 0.01, 25 rad/s, e_N 1 with the balls in grooves) runs ``--t-end`` seconds at
each tolerance (``solver.adaptive_retries`` 0) and with each fixed step (output every 0.1 ms),
every run with ``solver.on_nonconvergence: warn``. Printed per run: the steps taken, the
largest energy that steps created together (the energy audit's window gain, C minus its
lowest value before, without the restart after a flagged window) against what the audit allows
there, and the cumulative energy error C at the end (negative: energy dissipated by friction,
the cage's dampers and the scheme), and the time loop's integration time.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from _common import point_twin

from simcore.model import SolverSettings
from simcore.model.mechanism import crank_slider
from simcore.runner import warm_up


def twin(point, t_end: float, overrides) -> dict:
    """The twin's configuration of ``point`` (clearance, mu, omega0, e_N), ``t_end`` [s]."""
    cfg = point_twin(point, 1.0, overrides)  # (its length is set here, not by revolutions)
    cfg["solver"].update(t_end=t_end, adaptive_retries=0, on_nonconvergence="warn")
    return cfg


def measure(cfg: dict, **changes) -> tuple:
    """(steps, largest window gain [J], allowed there [J], C at the end [J], time [s])."""
    model = crank_slider(cfg["model"])[0]
    settings = SolverSettings.from_config(cfg, **changes)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        traj = model.simulate(settings)
    audit = traj.extras["energy_audit"]
    C = audit.cumulative
    window = C - np.minimum.accumulate(C)  # (the audit's, without its restarts)
    k = int(np.argmax(window))
    records = traj.extras.get("adaptive")
    steps = records["n_steps_accepted"] if records else settings.n_steps
    return steps, window[k], audit.tolerance[k], C[-1], traj.wall_time_s


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--point", default="4e-4,0.01,25,1.0",
                        help="clearance [m], mu, omega0 [rad/s], e_N")
    parser.add_argument("--tols", type=float, nargs="*", default=[1e-8, 1e-9, 1e-10, 1e-11],
                        help="adaptive tolerances [m]")
    parser.add_argument("--fixed", type=float, nargs="*", default=[5e-7, 1e-7],
                        help="fixed steps [s]")
    parser.add_argument("--t-end", type=float, default=0.3, help="run length [s]")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a configuration override (default: the balls in grooves)")
    args = parser.parse_args(argv)
    point = tuple(float(x) for x in args.point.split(","))
    overrides = ["model.contact_geometry=groove", *args.set]
    cfg = twin(point, args.t_end, overrides)
    warm_up(cfg)  # the kernels of both time loops, adaptive and fixed
    warm_up({**cfg, "solver": {**cfg["solver"], "adaptive": False}})
    print(f"point {point}, {args.t_end} s, overrides {overrides}")
    print(f"{'run':>16} {'steps':>10} {'window gain [J]':>16} {'allowed [J]':>12} "
          f"{'C end [J]':>10} {'time [s]':>9}")
    runs = [(f"tol {tol:g} m", dict(adaptive_tol=tol)) for tol in args.tols]
    out_every = lambda h: round(float(cfg["solver"]["output_dt"]) / h)  # noqa: E731
    runs += [(f"fixed {h:g} s", dict(adaptive=False, dt=h, output_every=out_every(h)))
             for h in args.fixed]
    for name, changes in runs:
        steps, gain, allowed, c_end, seconds = measure(cfg, **changes)
        print(f"{name:>16} {steps:>10,} {gain:>16.4f} {allowed:>12.4f} {c_end:>10.3f} "
              f"{seconds:>9.1f}")


if __name__ == "__main__":
    main()
