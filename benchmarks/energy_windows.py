"""Window gains of the energy audit (docs/reliability.md, section 3): the largest energy that
steps of a run created together, relative to the run's energy scale, against
``solver.energy_tol`` (5e-3), on four sets of runs:

* ``grid``: every nonsmooth run of the default study (config/config.yaml, 81 points);
* ``fuzz``: the 150 random configurations of ``fuzz_corners.py`` (seed 11, 0.05 s);
* ``conservative``: e_N = 1, mu = 0, no cage damping, rho_inf = 1, both drives, omega0 50 and
  300 rad/s, dt 1e-5, 4e-5, 1.6e-4 s, 0.05 s each;
* ``twins``: compliant twins (adaptive steps, rho_inf 0.5) of three grid points over 2 to 5 s,
  and a conservative one over 0.3 s.

Every run with ``solver.on_nonconvergence: warn``; prints per set the largest window gain, the
largest single step's gain and how many runs have a row flagged (a window flagged starts the
next one, so a flagged run's largest window is near the tolerance; its balance, E_end - E_0 -
drive work relative to the scale, says how far it climbed).

    PYTHONPATH=. python benchmarks/energy_windows.py [SET ...]
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _run(cfg):
    import simcore

    cfg["solver"]["on_nonconvergence"] = "warn"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = simcore.run(cfg)
    return (ds.attrs["energy_max_window_gain_relative"], ds.attrs["energy_max_gain_relative"],
            ds.attrs["n_energy_gain_steps"], ds.attrs["energy_balance_relative"])


def grid():
    import simcore
    from simcore.study import plan

    cfg = simcore.load_config(ROOT / "config" / "config.yaml")
    for run in plan.plan_runs(cfg):
        if run.model == "nonsmooth":
            yield str(run.point), _run(simcore.validate_config(run.config))


def fuzz():
    from fuzz_corners import draw

    import simcore

    rng = np.random.default_rng(11)
    for i in range(150):
        cfg = simcore.load_config(overrides=draw(rng, 0.05))
        try:
            yield f"draw {i}", _run(cfg)
        except simcore.ConfigError:  # refused by the dt limit
            continue


def conservative():
    import simcore

    for drive in ("free", "constant"):
        for omega0 in (50.0, 300.0):
            for dt in (1e-5, 4e-5, 1.6e-4):
                cfg = simcore.load_config(overrides=[
                    "model.e_N=1", "model.mu=0", "model.cage_damping=0", "solver.rho_inf=1",
                    f"model.drive={drive}", f"model.omega0={omega0}", f"solver.dt={dt}",
                    "solver.t_end=0.05", "solver.on_unresolved_dt=warn"])
                yield f"{drive} {omega0} rad/s dt {dt}", _run(cfg)


def twins():
    import simcore

    twin = ["model.contact_model=compliant", "solver.adaptive=true", "solver.output_dt=1e-4"]
    cases = {"reference point, 5 s": ["solver.t_end=5.0", "solver.rho_inf=0.5"],
             "100 rad/s, 2e-5 m, e_N 0.7, 2 s": ["solver.t_end=2.0", "model.omega0=100",
                                                   "model.clearance=2e-5", "model.e_N=0.7",
                                                   "solver.rho_inf=0.5"],
             "100 rad/s, mu 0, 2 s": ["solver.t_end=2.0", "model.omega0=100", "model.mu=0",
                                      "solver.rho_inf=0.5"],
             "conservative, 0.3 s": ["solver.t_end=0.3", "solver.rho_inf=1", "model.e_N=1",
                                     "model.mu=0", "model.cage_damping=0"]}
    for name, overrides in cases.items():
        cfg = simcore.load_config(ROOT / "config" / "config.yaml", overrides=twin + overrides)
        yield name, _run(cfg)


SETS = {"grid": grid, "fuzz": fuzz, "conservative": conservative, "twins": twins}


def main(names):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    for name in names:
        rows = list(SETS[name]())
        window = max(rows, key=lambda r: r[1][0])
        flagged = sum(r[1][2] > 0 for r in rows)
        print(f"{name}: {len(rows)} runs; largest window gain {window[1][0]:.2g} ({window[0]}); "
              f"largest step gain {max(r[1][1] for r in rows):.2g}; runs with a flagged row: "
              f"{flagged}", flush=True)
        if name in ("conservative", "twins"):
            for label, (w, step, n, balance) in rows:
                print(f"  {label}: window {w:.2g}, step {step:.2g}, rows flagged {n}, "
                      f"balance {balance:+.2g}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or list(SETS))
