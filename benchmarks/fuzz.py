"""Random configurations: does the bearing stay whole, and is every violation flagged?

    nice python benchmarks/fuzz.py [--runs 300] [--compliant 40] [--seed 2611] [--t-end 0.05]
                                   [--no-guards] [--adaptive] [--groove] [--timeout 300]
                                   [--json FILE] [--set KEY=VALUE ...]

Each configuration draws clearance 1e-6..2e-3 m, mu 0..0.5, omega0 1..400 rad/s, e_N and e_T
0..1, 3..22 balls, cage stiffness 1e3..1e7 N/m, cage damping 0 (one in four) or 1..1e4 N s/m,
dt 1e-5..5e-4 s (log-uniform where the range spans decades) and the drive; ``--compliant`` of
them use the compliant contact model, their step then at most the one that resolves a Hertz
contact (``simcore.config.limits.check_contact_step``; the step is the one drawn where that
allows it); with ``--adaptive`` they are a study's compliant twins instead (steel, E = 2.1e11
Pa; :func:`simcore.study.plan.twin_config`: adaptive steps of at most the drawn step, rho_inf
``analysis.twin_rho_inf``). With ``--groove`` every run has its balls in grooves
(``model.contact_geometry: groove``), each race's conformity drawn in 0.505..0.6 from a
generator of its own (the other draws stay those without the option). Every run uses the
default settings (guard contacts on unless ``--no-guards``) except
``solver.on_nonconvergence = warn``, so that flagged steps are counted instead of stopping the
run.

For every run that is not refused before it starts, the invariants of the bearing are
recomputed here from the stored arrays, independently of :mod:`simcore.model.integrity`:

- journal offset: the distance of the outer ring's centre from the inner ring's, against the
  rings' land gap plus twice the accepted Hertz deflection (``solver.max_indentation`` r_B);
- ball spacing: the closest pair of ball centres, against a diameter minus that deflection;
- slider reach: L2 - L1 - e <= x <= L1 + L2 + e (e the offset's bound);
- indentation (compliant): the deepest contact, against ``solver.max_indentation`` r_B;
- finite: every stored number finite.

Each run is a process of its own (``--one``), stopped after ``--timeout`` seconds: a run that
takes longer is counted as such, with its configuration.

Counted: refused before the run (one line), stopped with an error (a non-finite state or a
singular matrix, one line), crashes (any other exception, or a process that died: must be 0),
runs over the time limit, runs with a NaN (must be 0), runs where a row violates an invariant
and is not flagged in ``converged`` (must be 0), runs with flagged rows and by which check or
cause, and runs where the guard contacts closed. The last line reads
``unflagged: <runs> crashes: <runs> nan: <runs>`` (the slow test checks it).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
import traceback
import warnings
from collections import Counter

import numpy as np
from _common import as_overrides, draw_model, log_uniform


def draw(rng, t_end: float, compliant: bool, adaptive: bool = False) -> list[str]:
    """One random configuration, as ``section.key=value`` overrides; with ``adaptive`` a
    compliant one is steel with ``solver.adaptive`` set, which :func:`resolvable` makes a
    study's twin (the same draws of the generator)."""
    model = draw_model(rng)
    solver = dict(dt=log_uniform(rng, 1e-5, 5e-4), t_end=t_end, on_nonconvergence="warn")
    if compliant:
        model["contact_model"] = "compliant"
        if adaptive:
            model["youngs_modulus"] = 2.1e11
            solver["adaptive"] = True
    return as_overrides(model, solver)


def resolvable(cfg: dict) -> dict:
    """A compliant configuration with its step lowered to the one that resolves a Hertz
    contact in ``MIN_CONTACT_STEPS`` steps, when the drawn step is larger; one with adaptive
    steps the study's twin of its configuration (:func:`simcore.study.plan.twin_config`: steps
    of at most the drawn one, ``analysis.twin_rho_inf``; checked against ``solver.dt_min``)."""
    from simcore.config import validate_config
    from simcore.config.limits import MIN_CONTACT_STEPS, hertz_contact_time
    from simcore.study.plan import twin_config

    if cfg["model"]["contact_model"] != "compliant":
        return cfg
    if cfg["solver"]["adaptive"]:
        return validate_config(twin_config(cfg))
    limit = 0.99 * hertz_contact_time(cfg["model"]) / MIN_CONTACT_STEPS
    if cfg["solver"]["dt"] > limit:
        cfg["solver"]["dt"] = limit
    return validate_config(cfg)


def invariants(ds, cfg: dict) -> dict:
    """Rows (output samples after t0) that break each invariant, recomputed from the run
    file's arrays; each a boolean array."""
    from simcore.model.bearing import BearingGeometry
    from simcore.model.mechanism import crank_slider

    model = cfg["model"]
    _, layout = crank_slider(model)
    geometry = BearingGeometry.from_model(model)
    pos, ang = ds["position"].values[1:], ds["angle"].values[1:]

    def point(body, local):
        c, s = np.cos(ang[:, body]), np.sin(ang[:, body])
        return (pos[:, body, 0] + c * local[0] - s * local[1],
                pos[:, body, 1] + s * local[0] + c * local[1])

    tol = cfg["solver"]["tol"] * cfg["solver"]["dt"]
    deflection = cfg["solver"]["max_indentation"] * geometry.ball_radius
    ax, ay = point(layout.crank, layout.crank_pin)
    cx, cy = point(layout.rod, layout.rod_big_end)
    bound = geometry.land_gap + 2 * deflection + tol
    balls = pos[:, layout.balls, :]
    closest = np.full(balls.shape[0], np.inf)
    for i in range(balls.shape[1]):
        for j in range(i + 1, balls.shape[1]):
            closest = np.minimum(closest, np.linalg.norm(balls[:, i] - balls[:, j], axis=1))
    x = pos[:, layout.slider, 0]
    L1, L2 = model["crank_length"], model["rod_length"]
    broken = {
        "journal offset": ~(np.hypot(cx - ax, cy - ay) <= bound),
        "ball spacing": ~(closest >= 2 * geometry.ball_radius - deflection - tol),
        "slider reach": ~((x >= L2 - L1 - bound) & (x <= L1 + L2 + bound)),
    }
    if model["contact_model"] == "compliant":
        gaps = [ds["gap_N"].values[1:]]
        if "guard_gap_N" in ds:
            gaps.append(ds["guard_gap_N"].values[1:])
        broken["indentation"] = ~(np.concatenate(gaps, axis=1).min(axis=1) >= -deflection)
    return broken


def run_one(overrides: list[str]) -> dict:
    """Run one configuration; what happened, what it flagged, what it broke."""
    import simcore
    from simcore.config import ConfigError

    record = {"overrides": overrides}
    try:
        cfg = resolvable(simcore.load_config(overrides=overrides))
        record["dt"] = cfg["solver"]["dt"]
        record["compliant"] = cfg["model"]["contact_model"] == "compliant"
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ds = simcore.run(cfg)
    except ConfigError as exc:
        return dict(record, outcome="refused", why=str(exc).split(":")[0])
    except simcore.SolverError as exc:
        return dict(record, outcome="error", why=str(exc)[:160])
    except Exception:  # noqa: BLE001 - a crash is what the fuzz looks for
        return dict(record, outcome="crash", why=traceback.format_exc(limit=3)[-400:])
    keep = [v for v in ds.data_vars if ds[v].dtype.kind == "f"]
    nan = any(not np.all(np.isfinite(ds[v].values)) for v in keep)
    flagged = ds["converged"].values[1:] == 0
    broken = invariants(ds, cfg)
    unflagged = {name: int((rows & ~flagged).sum()) for name, rows in broken.items()}
    causes = Counter()
    for w in caught:
        text = str(w.message)
        if "integrity check" in text:
            causes[text.split("'")[1]] += 1
        elif "energy audit" in text:
            causes["energy audit"] += 1
        elif "did not converge" in text:
            causes["not converged"] += 1
    return dict(record, outcome="ran", nan=bool(nan), flagged_rows=int(flagged.sum()),
                rows=int(flagged.size), broken={k: int(v.sum()) for k, v in broken.items()},
                unflagged=unflagged, causes=dict(causes),
                integrity=ds.attrs.get("integrity_violations", "none"),
                guard_ball_ball=int(ds.attrs.get("guard_ball_ball_closed_samples", 0)),
                guard_rings=int(ds.attrs.get("guard_rings_closed_samples", 0)),
                wall_time_s=float(ds.attrs["wall_time_s"]))


def summary(records: list[dict]) -> list[str]:
    """The table of the fuzz, in lines."""
    lines = []
    for kind in ("nonsmooth", "compliant", "all"):
        rs = [r for r in records if kind == "all" or r.get("compliant", False) == (
            kind == "compliant")]
        ran = [r for r in rs if r["outcome"] == "ran"]
        causes = Counter()
        for r in ran:
            causes.update({k: 1 for k in r["causes"]})
        lines.append(
            f"{kind:9s} runs {len(rs):4d}: refused {sum(r['outcome'] == 'refused' for r in rs)}, "
            f"stopped with an error {sum(r['outcome'] == 'error' for r in rs)}, crashes "
            f"{sum(r['outcome'] == 'crash' for r in rs)}, over the time limit "
            f"{sum(r['outcome'] == 'timeout' for r in rs)}, ran {len(ran)}; NaN "
            f"{sum(r['nan'] for r in ran)}; runs with flagged rows "
            f"{sum(r['flagged_rows'] > 0 for r in ran)} (by cause, runs: {dict(causes)}); runs "
            f"breaking an invariant {sum(any(r['broken'].values()) for r in ran)}, of them "
            f"unflagged {sum(any(r['unflagged'].values()) for r in ran)}; guard contacts "
            f"closed: ball-ball in {sum(r['guard_ball_ball'] > 0 for r in ran)} runs, rings in "
            f"{sum(r['guard_rings'] > 0 for r in ran)}")
    refused = Counter(r["why"] for r in records if r["outcome"] == "refused")
    lines.append(f"refused by key: {dict(refused)}")
    times = [r["wall_time_s"] for r in records if r["outcome"] == "ran"]
    if times:
        lines.append(f"integration time of a run: median {np.median(times):.2f} s, largest "
                     f"{max(times):.1f} s")
    for r in records:
        if r["outcome"] in ("error", "crash", "timeout"):
            lines.append(f"{r['outcome']}: {' '.join(r['overrides'])}: {r['why']}")
    ran = [r for r in records if r["outcome"] == "ran"]
    lines.append(f"unflagged: {sum(any(r['unflagged'].values()) for r in ran)} crashes: "
                 f"{sum(r['outcome'] == 'crash' for r in records)} nan: "
                 f"{sum(r['nan'] for r in ran)}")
    return lines


def run_in_process(overrides: list[str], timeout: float) -> dict:
    """:func:`run_one` in a process of its own, stopped after ``timeout`` seconds."""
    cmd = [sys.executable, __file__, "--one", json.dumps(overrides)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"overrides": overrides, "outcome": "timeout",
                "why": f"still running after {timeout:g} s"}
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        return {"overrides": overrides, "outcome": "crash",
                "why": f"exit {proc.returncode}: {proc.stderr[-400:]}"}
    return json.loads(lines[-1])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--runs", type=int, default=300)
    p.add_argument("--compliant", type=int, default=40, help="of them compliant")
    p.add_argument("--seed", type=int, default=2611)
    p.add_argument("--t-end", type=float, default=0.05, help="duration of each run [s]")
    p.add_argument("--no-guards", action="store_true", help="model.guard_contacts = false")
    p.add_argument("--adaptive", action="store_true",
                   help="compliant runs as a study's twins: steel, adaptive steps")
    p.add_argument("--groove", action="store_true",
                   help="balls in grooves, conformities drawn in 0.505..0.6")
    p.add_argument("--timeout", type=float, default=300.0,
                   help="seconds after which a run's process is stopped")
    p.add_argument("--json", default=None, help="write every run's record to this file")
    p.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                   help="other settings of every run, e.g. solver.onset_speed=last_open")
    p.add_argument("--one", default=None, help=argparse.SUPPRESS)  # a child: one run
    args = p.parse_args(argv)
    if args.one is not None:
        print(json.dumps(run_one(json.loads(args.one)), default=str))
        return 0
    rng = np.random.default_rng(args.seed)
    compliant = set(rng.choice(args.runs, size=min(args.compliant, args.runs), replace=False))
    groove_rng = np.random.default_rng([args.seed, 1])  # (the main draws stay as they were)
    records = []
    start = time.perf_counter()
    for i in range(args.runs):
        overrides = draw(rng, args.t_end, i in compliant, args.adaptive)
        if args.no_guards:
            overrides.append("model.guard_contacts=false")
        overrides += args.set
        if args.groove:
            overrides += ["model.contact_geometry=groove", *(
                f"model.{race}_conformity={groove_rng.uniform(0.505, 0.6)!r}"
                for race in ("inner", "outer"))]
        records.append(run_in_process(overrides, args.timeout))
        print(f"{i + 1}/{args.runs} {records[-1]['outcome']} "
              f"{records[-1].get('integrity', '')} {records[-1].get('causes', '')}",
              file=sys.stderr, flush=True)
    print(f"{args.runs} configurations ({len(compliant)} compliant"
          f"{', adaptive' if args.adaptive else ''}{', in grooves' if args.groove else ''}), "
          f"t_end = {args.t_end} s, "
          f"seed {args.seed}, guard contacts {'off' if args.no_guards else 'on'}, "
          f"{time.perf_counter() - start:.0f} s")
    for line in summary(records):
        print(line)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(records, fh, indent=1, default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
