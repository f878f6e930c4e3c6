"""How much the study's steady peak forces move with the initial state, the step and the
compliant model's settings, at two grid points, both contact models.

For each point (default: the reference point, 4e-4 m, mu 0.01, 50 rad/s, e_N 0.9, and a
small-clearance point, 2e-5 m, 100 rad/s, e_N 0.7; steel, constant drive, 1 start-up and 3
steady revolutions, as the default study) it runs the nonsmooth model and its compliant twin
(the twin's step: the Hertz contact time over analysis.zoom_steps_per_contact, a whole fraction
of the output step 1e-4 s), then again with

* ball 0 moved 1 nm along the pitch circle at the start (``model.ball0_shift``; both models; a
  radial shift of a ball is erased by the nonsmooth model's position correction as soon as the
  ball is pinched),
* half the step (both models),
* the compliant model's other damping laws (hunt_crossley, lankarani_nikravesh),
* the compliant model's friction regularisation speed 1e-3 and 1e-2 m/s (default 1e-4),

and prints ``peak_force`` and ``peak_force_rev_median`` per race (the summary's numbers,
:func:`analysis.summary.point_numbers`) with their change against the base run.

    python benchmarks/method_sensitivity.py [--point reference|small] [--revolutions 3]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

POINTS = {
    "reference": {"clearance": 4e-4, "mu": 0.01, "omega0": 50.0, "e_N": 0.9},
    "small": {"clearance": 2e-5, "mu": 0.01, "omega0": 100.0, "e_N": 0.7},
}
SETTLE = 1.0
OUTPUT_DT = 1e-4
SHIFT = 1e-9  # [m] the change of the initial state


def base_config(point: dict, model: str, revolutions: float) -> dict:
    """The study's run of ``point`` with ``model`` (constant drive, steel)."""
    import simcore
    from simcore.config.limits import hertz_contact_time

    cfg = simcore.validate_config({
        "model": dict(point, drive="constant", youngs_modulus=2.1e11, contact_model=model),
        "solver": {"dt": OUTPUT_DT},
        "analysis": {"settle": SETTLE}})
    steps = math.ceil((SETTLE + revolutions) * 2 * math.pi / point["omega0"] / OUTPUT_DT - 1e-9)
    cfg["solver"]["t_end"] = steps * OUTPUT_DT
    if model == "compliant":
        hertz = hertz_contact_time(cfg["model"]) / cfg["analysis"]["zoom_steps_per_contact"]
        cfg["solver"]["dt"] = OUTPUT_DT / max(1, math.ceil(OUTPUT_DT / hertz - 1e-9))
        cfg["solver"]["output_dt"] = OUTPUT_DT
        # the audit of a sampled compliant run may count the drive's work at the end of an
        # output interval: steps it flags are counted in converged_fraction, not fatal here
        cfg["solver"]["on_nonconvergence"] = "warn"
    return simcore.validate_config(cfg)


def numbers(ds, cfg) -> dict:
    """peak_force and peak_force_rev_median per race, and the fraction of converged steps."""
    from analysis import extract_impacts
    from analysis.summary import point_numbers

    settings = dict(cfg["analysis"])
    table = None if cfg["model"]["contact_model"] == "compliant" else extract_impacts(ds)
    n = point_numbers(ds, table, settings)
    return {"peak": n["peak_force"], "median": n["peak_force_rev_median"],
            "converged": float(n["converged_fraction"])}


def change(values, reference) -> str:
    """Relative changes, outer race first."""
    return ", ".join(f"{(v / r - 1) * 100:+.1f} %" if np.isfinite(v / r) else "–"
                     for v, r in zip(values[::-1], reference[::-1], strict=True))


def variants(point: dict, revolutions: float):
    """(label, model, config) of every run."""
    for model in ("nonsmooth", "compliant"):
        cfg = base_config(point, model, revolutions)
        yield "base", model, cfg
        yield "initial state +1 nm", model, dict(cfg, model=dict(cfg["model"],
                                                                 ball0_shift=SHIFT))
        half = dict(cfg, solver=dict(cfg["solver"], dt=cfg["solver"]["dt"] / 2))
        yield f"dt / 2 ({half['solver']['dt']:.3g} s)", model, half
        if model == "compliant":
            for law in ("hunt_crossley", "lankarani_nikravesh"):
                yield f"damping_law {law}", model, dict(cfg, model=dict(
                    cfg["model"], damping_law=law))
            for v in (1e-3, 1e-2):
                yield f"friction_regularization {v:g} m/s", model, dict(cfg, model=dict(
                    cfg["model"], friction_regularization=v))


def main(argv=None) -> int:
    import simcore

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--point", choices=sorted(POINTS), action="append",
                   help="grid point (repeatable; default: both)")
    p.add_argument("--revolutions", type=float, default=3.0, help="steady revolutions per run")
    args = p.parse_args(argv)
    for name in args.point or ["reference", "small"]:
        point = POINTS[name]
        print(f"\n## {name} point: " + ", ".join(f"{k} = {v:g}" for k, v in point.items())
              + f", steel, constant drive, {SETTLE:g} + {args.revolutions:g} revolutions")
        print("| model | run | peak outer [N] | peak inner [N] | median outer [N] | "
              "median inner [N] | change of peak (outer, inner) | change of median | "
              "converged | wall [s] |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        base = {}
        for label, model, cfg in variants(point, args.revolutions):
            start = time.perf_counter()
            out = numbers(simcore.run(cfg), cfg)
            wall = time.perf_counter() - start
            if label == "base":
                base[model] = out

            print(f"| {model} | {label} | {out['peak'][1]:.0f} | {out['peak'][0]:.0f} | "
                  f"{out['median'][1]:.0f} | {out['median'][0]:.0f} | "
                  f"{change(out['peak'], base[model]['peak'])} | "
                  f"{change(out['median'], base[model]['median'])} | "
                  f"{out['converged']:.4f} | {wall:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
