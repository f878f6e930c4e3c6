"""Where the compliant twin spends its adaptive steps, against fixed steps.

    python benchmarks/twin_steps.py                       the reference point and the
                                                          small-clearance point, 5 steady
                                                          revolutions each
    python benchmarks/twin_steps.py --points 4e-4,0.01,50,0.9 --revolutions 20
    python benchmarks/twin_steps.py --fixed 4e-6 2e-6 --set model.cage_damping=100
    python benchmarks/twin_steps.py --onset-steps 40 20 10   the onset step at a 40th, 20th
                                                          and 10th of a contact time

Each run is the study's twin of a point (:func:`simcore.study.plan.twin_config`: steel,
adaptive steps of at most the output step, rho_inf 0.5) over the start-up revolution and
``--revolutions`` steady ones. Its run file's ``steps`` (the steps of each output interval)
are split over the steady intervals by what happens in them, read from ``F_N`` (the largest
force of each contact in the interval): an interval in which some contact carries force and
carried none in the interval before holds an onset (a contact closing); the others are split
by how many contacts carry force. Per fixed step of ``--fixed`` it prints the fixed run's steps
per revolution over the twin's, and what that ratio would be if the intervals with an onset
cost no step at all (a bound on what any cheaper treatment of onsets could give at this error
control).
"""

from __future__ import annotations

import argparse

import numpy as np
from _common import point_twin

import simcore
from analysis.summary import SteadyWindow

POINTS = ("4e-4,0.01,50,0.9", "2e-5,0.01,100,0.7")  # clearance [m], mu, omega0 [rad/s], e_N


def step_shares(steps: np.ndarray, force: np.ndarray) -> dict:
    """The steady intervals' steps by kind: ``steps`` (interval), ``force`` (interval, contact)
    [N], both the steady rows and the row before them (which only sets what was loaded
    before). Returns {kind: (intervals, steps)}."""
    loaded = force > 0.0
    onset = (loaded[1:] & ~loaded[:-1]).any(axis=1)
    n_loaded = loaded[1:].sum(axis=1)
    steps = steps[1:]
    kinds = {"with an onset": onset}
    for low, high, label in ((0, 2, "0-2"), (3, 6, "3-6"), (7, force.shape[1], "7 or more")):
        kinds[f"no onset, {label} contacts loaded"] = ~onset & (n_loaded >= low) & (
            n_loaded <= high)
    return {kind: (int(rows.sum()), int(steps[rows].sum())) for kind, rows in kinds.items()}


def run_twin(cfg: dict, onset_steps: float | None):
    """The twin's run dataset (:func:`simcore.run`), or with ``onset_steps`` (a field of
    :class:`simcore.model.SolverSettings`, not a configuration key: a closing contact's step is
    at most its Hertz contact time over this many) the same run through the model's API."""
    if onset_steps is None:
        return simcore.run(cfg)
    from simcore.config import validate_config
    from simcore.io import trajectory_dataset
    from simcore.model import SolverSettings
    from simcore.model.mechanism import crank_slider

    cfg = validate_config(cfg)
    model, layout = crank_slider(cfg["model"])
    traj = model.simulate(SolverSettings.from_config(cfg, onset_steps=onset_steps))
    return trajectory_dataset(traj, model, layout, cfg)


def report(point: str, revolutions: float, fixed, overrides, onset_steps=None) -> None:
    """Run the twin of ``point`` ("clearance,mu,omega0,e_N") and print its steps over the
    steady window (after ``analysis.settle``) by kind of interval, and against each fixed
    step of ``fixed`` [s]."""
    cfg = point_twin(tuple(point.split(",")), revolutions, overrides)
    if not cfg["solver"]["adaptive"]:
        raise SystemExit("twin_steps.py: the twin's steps are adaptive; leave solver.adaptive")
    ds = run_twin(cfg, onset_steps)
    window = SteadyWindow.of_run(ds, float(cfg["analysis"]["settle"]))
    time = ds["time"].values
    first = int(np.searchsorted(time, window.settle_time - 1e-12))  # the window's first row
    steps = ds["steps"].values[first:].astype(np.int64)  # (which only says what was loaded)
    force = ds["F_N"].values[first:]
    n_rev = window.revolutions
    period = (time[-1] - time[first]) / n_rev  # the mean revolution [s]
    total = int(steps[1:].sum())
    per_rev = total / n_rev
    changed = [*overrides, *([f"onset_steps {onset_steps:g}"] if onset_steps else [])]
    print(f"\npoint {point} ({', '.join(changed) or 'study settings'}): {n_rev:.2f} steady "
          f"revolutions, {per_rev:,.0f} steps per revolution, "
          f"{total / (len(steps) - 1):.1f} per output interval of "
          f"{float(cfg['solver']['output_dt']) * 1e6:g} us (whole run: "
          f"{int(ds.attrs['n_steps_accepted']):,} accepted, {int(ds.attrs['n_steps_rejected']):,}"
          f" redone)")
    shares = step_shares(steps, force)
    print(f"  {'intervals':<36} {'count':>7} {'steps':>9} {'share':>6} {'per interval':>13}")
    for kind, (rows, n) in shares.items():
        mean = n / rows if rows else float("nan")
        print(f"  {kind:<36} {rows:>7,} {n:>9,} {n / total:>6.0%} {mean:>13.1f}")
    without = total - shares["with an onset"][1]
    for dt in fixed:
        fixed_rev = period / dt
        print(f"  fixed {dt * 1e6:g} us: {fixed_rev:,.0f} steps per revolution, "
              f"{fixed_rev / per_rev:.2f} times the twin's; "
              f"{fixed_rev / (without / n_rev):.2f} times if onsets cost no step")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", nargs="+", default=list(POINTS),
                        help="clearance,mu,omega0,e_N of each point")
    parser.add_argument("--revolutions", type=float, default=5.0)
    parser.add_argument("--fixed", type=float, nargs="*", default=[4e-6, 2e-6],
                        help="fixed steps to compare with [s]")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                        help="further overrides of the study configuration")
    parser.add_argument("--onset-steps", type=float, nargs="+", default=[None],
                        help="runs with a closing contact's step at most its Hertz contact "
                        "time over each of these (default: the solver's, 40)")
    args = parser.parse_args()
    for point in args.points:
        for onset_steps in args.onset_steps:
            report(point, args.revolutions, args.fixed, args.set, onset_steps)


if __name__ == "__main__":
    main()
