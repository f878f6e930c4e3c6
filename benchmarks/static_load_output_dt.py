"""How much the ISO 76 numbers of a compliant twin move with its output interval.

P0 (``static_equivalent_load``) is the largest radial load the bearing transmits in the steady
window, as a mean over one output interval (``solver.output_dt``); s0 = C0 / P0. For each point
(default: the reference point, 4e-4 m, mu 0.01, 50 rad/s, e_N 0.9, and a small-clearance point,
2e-5 m, 100 rad/s, e_N 0.7; steel, constant drive, 1 start-up and 3 steady revolutions, as the
default study) the study's twin (adaptive steps of at most the output interval) runs at each
output interval and prints P0, s0 and the dynamic equivalent load P of L10
(:func:`analysis.run_life.compliant_life`). The output grid also cuts the adaptive steps, so at
a chaotic point each interval gives another trajectory as well.

    python benchmarks/static_load_output_dt.py [--points C,MU,OMEGA0,E_N ...]
        [--output-dt 2e-4 1e-4 5e-5 2.5e-5]
"""

from __future__ import annotations

import argparse

import simcore
from analysis.run_life import compliant_life
from analysis.summary import SteadyWindow
from simcore.study import plan

POINTS = ("4e-4,0.01,50,0.9", "2e-5,0.01,100,0.7")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", nargs="+", default=list(POINTS), metavar="C,MU,OMEGA0,E_N")
    parser.add_argument("--output-dt", type=float, nargs="+", default=[2e-4, 1e-4, 5e-5, 2.5e-5])
    args = parser.parse_args()
    for point in args.points:
        clearance, mu, omega0, e_N = point.split(",")
        cfg = simcore.load_config("config/config.yaml", overrides=[
            "study.revolutions=3", f"sweep.clearance=[{clearance}]", f"sweep.mu=[{mu}]",
            f"sweep.omega0=[{omega0}]", f"sweep.e_N=[{e_N}]"])
        twin = [r for r in plan.plan_runs(cfg) if r.model == "compliant"][0].config
        settle = float(twin["analysis"]["settle"])
        for output_dt in args.output_dt:
            run = simcore.run(dict(twin, solver=dict(twin["solver"], output_dt=output_dt,
                                                     dt=output_dt)))
            window = SteadyWindow.of_run(run, settle)
            out = compliant_life(run, window.settle_time, twin["analysis"])
            print(f"point {point}: output_dt {output_dt:g} s: P0 "
                  f"{out['static_equivalent_load']:.0f} N, s0 {out['static_safety_factor']:.3f}, "
                  f"P {out['equivalent_load']:.0f} N ({run.attrs['n_steps_accepted']} steps)",
                  flush=True)


if __name__ == "__main__":
    main()
