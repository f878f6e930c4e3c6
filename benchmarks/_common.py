"""Pieces the benchmark scripts share (imported as ``_common`` from a script in this folder)."""

from __future__ import annotations

import statistics
import time
from typing import NamedTuple

import numpy as np


def log_uniform(rng, low: float, high: float) -> float:
    """A number drawn log-uniformly in [low, high]."""
    return float(np.exp(rng.uniform(np.log(low), np.log(high))))


def draw_model(rng) -> dict:
    """A random ``model`` section of the fuzzers (``fuzz.py``, ``fuzz_corners.py``): the
    parameters over their whole allowed ranges, drawn in a fixed order (a seed gives the same
    configurations in both)."""
    return dict(clearance=log_uniform(rng, 1e-6, 2e-3), mu=float(rng.uniform(0, 0.5)),
                omega0=float(rng.uniform(1, 400)), e_N=float(rng.uniform(0, 1)),
                e_T=float(rng.uniform(0, 1)), n_balls=int(rng.integers(3, 23)),
                cage_stiffness=log_uniform(rng, 1e3, 1e7),
                cage_damping=0.0 if rng.uniform() < 0.25 else log_uniform(rng, 1.0, 1e4),
                drive=str(rng.choice(["free", "constant"])))


def as_overrides(model: dict, solver: dict) -> list[str]:
    """``section.key=value`` overrides of ``simcore.load_config`` from two sections."""
    return ([f"model.{k}={v}" for k, v in model.items()]
            + [f"solver.{k}={v}" for k, v in solver.items()])


class Timing(NamedTuple):
    """Times of repeated calls: the integration's wall times and the whole calls' CPU times [s],
    and the last call's result."""

    walls: list
    cpus: list
    result: object

    @property
    def wall(self) -> float:
        """Median wall time [s]."""
        return statistics.median(self.walls)

    @property
    def cpu(self) -> float:
        """Median CPU time [s]."""
        return statistics.median(self.cpus)


def timed_repeats(call, repeats: int, wall_time) -> Timing:
    """Run ``call()`` ``repeats`` times, with ``wall_time(result)`` the integration's wall
    time [s] (the run measures it itself) and the CPU time of each whole call."""
    walls, cpus = [], []
    for _ in range(repeats):
        c0 = time.process_time()
        result = call()
        cpus.append(time.process_time() - c0)
        walls.append(wall_time(result))
    return Timing(walls, cpus, result)


def steady_run_largest_impact():
    """The run of the default study's point at clearance 1e-4 m, omega0 = 50 rad/s (a steady
    run, whose loaded balls stay in contact with both races) and the time of its largest
    impact [s]: where ``bench_compliant.py`` and ``compare_compliant.py`` zoom."""
    import simcore
    from analysis.impacts import extract_impacts
    from simcore.config import load_config

    cfg = load_config("config/config.yaml", overrides=["model.clearance=1e-4",
                                                       "model.omega0=50.0"])
    run = simcore.run(cfg)
    a = cfg["analysis"]
    imp = extract_impacts(run, zero_tol=a["zero_tol"], zero_floor=a["zero_floor"],
                          r_eff=a["r_eff"], v_min=a["v_min"])
    return run, float(imp["time"].values[int(np.argmax(imp["impulse"].values))])


def point_twin(point, revolutions: float, overrides=()) -> dict:
    """The study twin's configuration (:func:`simcore.study.plan.twin_config`) of ``point``
    (clearance [m], mu, omega0 [rad/s], e_N) over the start-up revolution and ``revolutions``
    steady ones (``study.revolutions``), with the study configuration's ``overrides``."""
    import simcore
    from simcore.study import plan

    clearance, mu, omega0, e_n = point
    cfg = simcore.load_config("config/config.yaml", overrides=[
        f"study.revolutions={revolutions}", f"sweep.clearance=[{clearance}]",
        f"sweep.mu=[{mu}]", f"sweep.omega0=[{omega0}]", f"sweep.e_N=[{e_n}]", *overrides])
    return [r for r in plan.plan_runs(cfg) if r.model == "compliant"][0].config
