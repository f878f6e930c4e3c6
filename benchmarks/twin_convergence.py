"""Convergence of the compliant twin: steady peak force per race with its error-controlled
steps (``solver.adaptive_tol``) against fixed steps of N per Hertz contact time.

    python benchmarks/twin_convergence.py                       tol 1e-8, 1e-9, 1e-10 m;
                                                                fixed N = 20, 40, 80
    python benchmarks/twin_convergence.py --tols 1e-9 --n 40    others
    python benchmarks/twin_convergence.py --zooms               also the zooms' N
    python benchmarks/twin_convergence.py --rhos 0 0.5          adaptive runs at each rho_inf
    python benchmarks/twin_convergence.py --revolutions 3 --tols 1e-9 --rhos 0 0.5 --n
        --points 1e-4,0.05,25,1 ...                             the study's twins (1 + 3
                                                                revolutions) of other points
    python benchmarks/twin_convergence.py --revolutions 3 --tols 1e-9 --n
        --shifts 1e-9,-1e-9,2e-9 --points ...                   also the twin started with
                                                                ball 0 moved along the pitch
                                                                circle by each shift [m]

For each point (steel, constant drive, the default study's settings; clearance, mu, omega0,
e_N given below) the twin of :func:`simcore.study.plan.twin_config` (adaptive steps, at most
the output step) runs 1 + ``--revolutions`` crank revolutions at each tolerance, and the same
twin with fixed steps (:func:`simcore.study.plan.twin_step`: the Hertz contact time over N).
Printed per run: the steps taken, the largest ``F_N`` per race after the first revolution (the
study's steady window, ``analysis.settle`` = 1) and its change against the finest fixed N (or,
with ``--shifts``, against the unshifted twin), the median over revolutions of each
revolution's largest force, their spread ((largest - smallest) / median), and the run's
integration time.
With ``--zooms``, the compliant zooms of the nonsmooth run (``analysis.zoom_top`` largest
impacts) at each N: their ``F_max_zoom`` against the finest N.
"""

from __future__ import annotations

import argparse

import numpy as np

import simcore
from simcore.study import plan

POINTS = (  # (clearance [m], mu, omega0 [rad/s], e_N): the reference and a small clearance
    (4e-4, 0.01, 50.0, 0.9),
    (2e-5, 0.01, 100.0, 0.7),
)


def steady_peaks(ds, settle: float = 1.0):
    """(largest F_N per race, median over revolutions of each revolution's largest per race,
    spread of those) after ``settle`` crank revolutions [N, N, -]: the study summary's
    ``peak_force``, ``peak_force_rev_median`` and ``peak_force_rev_spread`` of the run
    (:func:`analysis.summary.compliant_numbers`)."""
    from analysis.summary import SteadyWindow, compliant_numbers

    numbers = compliant_numbers(ds, SteadyWindow.of_run(ds, settle), [], None)
    return tuple([float(f) for f in numbers[name]] for name in (
        "peak_force", "peak_force_rev_median", "peak_force_rev_spread"))


def twin_runs(cfg, tols, ns, rhos=(None,), shifts=()):
    """{label: (steps, peak, median and spread per race, integration time)} of the point's
    twin with adaptive steps at each tolerance (and each spectral radius of ``rhos``, None: the
    twin's own ``analysis.twin_rho_inf``; and, at the first tolerance and radius, ball 0 moved
    by each of ``shifts`` [m] at the start, beyond the configuration's ``model.ball0_shift``)
    and fixed steps at each N."""
    out = {}
    twin = [r for r in plan.plan_runs(cfg) if r.model == "compliant"][0].config
    out_dt = twin["solver"]["output_dt"]
    rho_twin = twin["solver"]["rho_inf"]
    base_shift = float(twin["model"]["ball0_shift"])
    for i, (rho, tol) in enumerate([(r, t) for r in rhos for t in tols]):
        rho = rho_twin if rho is None else rho
        twin["solver"].update(adaptive=True, adaptive_tol=tol, dt=out_dt, rho_inf=rho)
        for shift in (0.0, *shifts) if i == 0 else (0.0,):
            start = base_shift + shift
            ds = simcore.run(dict(twin, model=dict(twin["model"], ball0_shift=start)))
            label = f"adaptive tol={tol:.3g} m rho={rho:g}" + (
                f" shift={start:.3g} m" if start else "")
            out[label] = (int(ds.attrs["n_steps_accepted"]), *steady_peaks(ds),
                          ds.attrs["wall_time_s"])
    for n in sorted(ns):
        analysis = dict(twin["analysis"], zoom_steps_per_contact=n)
        dt = plan.twin_step(twin["model"], analysis, out_dt)
        twin["solver"].update(adaptive=False, dt=dt, rho_inf=rho_twin)
        ds = simcore.run(twin)
        steps = int(round(twin["solver"]["t_end"] / dt))
        out[f"fixed N={n} (dt={dt:.3g} s)"] = (steps, *steady_peaks(ds), ds.attrs["wall_time_s"])
    return out


def zoom_forces(cfg, ns):
    """{N: F_max_zoom of the zoomed rows} of the point's nonsmooth run."""
    from analysis import extract_impacts
    from analysis.zoom import add_zoom_forces

    ns_run = [r for r in plan.plan_runs(cfg) if r.model == "nonsmooth"][0]
    run = simcore.run(ns_run.config)
    table = extract_impacts(run, zero_tol=cfg["analysis"]["zero_tol"])
    zooms = {}
    for n in sorted(ns):
        # (loaded balls zoomed all the same: this compares the zoom's steps)
        zoomed = add_zoom_forces(run, table, zoom_top=cfg["analysis"]["zoom_top"],
                                 steps_per_contact=n, adaptive=False, loaded="zoom")
        f = np.asarray(zoomed["F_max_zoom"].values, dtype=float)
        zooms[n] = f[np.isfinite(f)]
    return zooms


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tols", type=float, nargs="*", default=[1e-8, 1e-9, 1e-10])
    parser.add_argument("--n", type=int, nargs="*", default=[20, 40, 80],
                        help="fixed steps per Hertz contact time (none: adaptive runs only)")
    parser.add_argument("--points", nargs="+", default=None, metavar="C,MU,OMEGA0,E_N",
                        help="grid points (default: the reference and a small clearance)")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                        help="other settings of the study, e.g. model.cage_damping=100")
    parser.add_argument("--rhos", type=float, nargs="*", default=[],
                        help="spectral radii of the adaptive runs (default: the twin's own)")
    parser.add_argument("--shifts", default="", metavar="S1,S2,...",
                        help="also the twin (first tolerance and radius) with ball 0 moved "
                             "along the pitch circle by each shift at the start [m], "
                             "comma-separated (a negative one too)")
    parser.add_argument("--revolutions", type=float, default=2.0)
    parser.add_argument("--zooms", action="store_true")
    args = parser.parse_args()
    points = ([tuple(float(x) for x in p.split(",")) for p in args.points] if args.points
              else POINTS)
    shifts = [float(x) for x in args.shifts.split(",") if x]
    for clearance, mu, omega0, e_N in points:
        cfg = simcore.load_config("config/config.yaml", overrides=[
            f"study.revolutions={args.revolutions}", f"sweep.clearance=[{clearance}]",
            f"sweep.mu=[{mu}]", f"sweep.omega0=[{omega0}]", f"sweep.e_N=[{e_N}]", *args.set])
        results = twin_runs(cfg, args.tols, args.n, args.rhos or (None,), shifts)
        finest, against = (list(results.values())[0], "unshifted") if shifts else (
            list(results.values())[-1] if args.n else None, f"N={max(args.n, default=0)}")
        print(f"point clearance={clearance} m, mu={mu}, omega0={omega0} rad/s, e_N={e_N}, "
              f"E={cfg['model']['youngs_modulus']:.3g} Pa:")
        for label, (steps, peak, median, spread, wall) in results.items():
            vs = ""
            if finest:
                change = [p / f - 1.0 for p, f in zip(peak, finest[1], strict=True)]
                vs = f" ({100 * change[0]:+.2f} %, {100 * change[1]:+.2f} % vs {against})"
            print(f"  {label:36s} {steps:9d} steps  peak inner/outer {peak[0]:8.1f} "
                  f"{peak[1]:8.1f} N{vs}; median per rev {median[0]:8.1f} {median[1]:8.1f} N; "
                  f"spread {100 * spread[0]:.1f} % {100 * spread[1]:.1f} %; {wall:.1f} s",
                  flush=True)
        if args.zooms:
            zooms = zoom_forces(cfg, args.n)
            best = zooms[max(zooms)]
            for n, f in zooms.items():
                if f.size == best.size and f.size:
                    change = np.max(np.abs(f / best - 1.0))
                    print(f"  zooms N={n:4d}: F_max_zoom " + " ".join(f"{x:.0f}" for x in f)
                          + f" N (largest change {100 * change:.2f} % vs N={max(zooms)})")


if __name__ == "__main__":
    main()
