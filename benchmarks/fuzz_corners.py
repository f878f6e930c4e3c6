"""Random configurations over the whole input range; counts of what the tool refuses and flags.

    PYTHONPATH=. python benchmarks/fuzz_corners.py [N] [T_END] [SEED] [MAX_HALVINGS] [MAX_ITER]
    (default 300 0.1 11 4)
    PYTHONPATH=. python benchmarks/fuzz_corners.py --hard [N] [T_END] [SEED] [MAX_ITER]
                                                       (default 16 0.02 5, the schema's cap)

Each configuration draws clearance 1e-6..2e-3 m, mu 0..0.5, omega0 1..400 rad/s, e_N and e_T
0..1, 3..22 balls, cage stiffness 1e3..1e7 N/m, cage damping 0 (one in four) or 1..1e4 N s/m,
dt 1e-5..5e-4 s, both drives, rho_inf 0..1 (log-uniform where the range spans decades), and is
run with the default policies except ``solver.on_nonconvergence = "warn"`` (so that the
unconverged steps can be counted instead of stopping the run) and ``solver.max_halvings =
MAX_HALVINGS`` (the retries of a failed step; 0: none).

Counted per region (drive x mu > 0.3, omega0 > 200, clearance > 1 mm, no cage damping):

- refused: stopped before the run by the step-size limit (``solver.dt``, one line);
- runs with a defect: at least one step flagged in ``converged`` (did not converge, or
  created energy), and the largest fraction of flagged steps;
- silent energy gain: a step marked converged whose energy error, recomputed here from the
  stored arrays (kinetic energy from v and the masses, gravity and cage springs from q, drive
  work from the torque), is above the audit's tolerance; must be 0;
- silent penetration: a step marked converged with a gap below -solver.tol * dt (the position
  tolerance); must be 0.

The last line reads ``silent: <gains> <penetrations>`` (the slow test checks it).

``--hard``: N configurations of the corner where nonsmooth steps fail most (constant drive,
mu 0.3..0.5, omega0 100..400 rad/s, clearance 1..2 mm, no cage damping; e_N, e_T, balls and
cage stiffness drawn as above; dt = 1e-4 s, halved until the step-size limit accepts it),
each run with ``solver.max_halvings`` 0 and 4 (``on_nonconvergence = "warn"``). Per
configuration: the steps flagged without retries, the steps retried and the steps still
flagged with them, the largest halving, and the CPU time of both runs (kernels warm).
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np
from _common import as_overrides, draw_model, log_uniform


def draw(rng, t_end):
    """One random configuration (overrides for simcore.load_config)."""
    model = draw_model(rng)
    solver = dict(dt=log_uniform(rng, 1e-5, 5e-4), rho_inf=float(rng.uniform(0, 1)), t_end=t_end,
                  on_nonconvergence="warn")
    return as_overrides(model, solver)


def draw_hard(rng, t_end):
    """One configuration of the hard corner (overrides for simcore.load_config)."""
    model = dict(clearance=float(rng.uniform(1e-3, 2e-3)), mu=float(rng.uniform(0.3, 0.5)),
                 omega0=float(rng.uniform(100, 400)), e_N=float(rng.uniform(0, 1)),
                 e_T=float(rng.uniform(0, 1)), n_balls=int(rng.integers(3, 23)),
                 cage_stiffness=float(np.exp(rng.uniform(np.log(1e3), np.log(1e7)))),
                 cage_damping=0.0, drive="constant")
    return ([f"model.{k}={v}" for k, v in model.items()]
            + [f"solver.t_end={t_end}", "solver.on_nonconvergence=warn"])


def accepted_dt(overrides, dt=1e-4):
    """The largest dt / 2^m that the step-size limit accepts for these overrides [s]."""
    import simcore
    from simcore.config.limits import check_run_of_config

    while True:
        cfg = simcore.load_config(overrides=overrides + [f"solver.dt={dt}"])
        try:
            check_run_of_config(cfg)
        except simcore.ConfigError:
            dt /= 2
        else:
            return dt


def hard_corners(n=16, t_end=0.02, seed=5, max_iter=None):
    """The table of ``--hard`` (see the module docstring); returns the steps still flagged
    with retries, summed over the configurations."""
    import simcore

    rng = np.random.default_rng(seed)
    simcore.run(simcore.load_config(overrides=["solver.t_end=0.001"]))  # compile or load
    print(f"{n} hard-corner configurations, t_end = {t_end} s, seed {seed}")
    print(f"{'mu':>5s} {'omega0':>7s} {'clear mm':>8s} {'balls':>5s} {'e_N':>5s} {'dt us':>6s} "
          f"{'steps':>6s} "
          f"{'flag(0)':>8s} {'retried':>8s} {'flag(4)':>8s} {'max L':>5s} {'cpu(0) s':>9s} "
          f"{'cpu(4) s':>9s}")
    totals = np.zeros(3, dtype=int)
    cpu = np.zeros(2)
    for _ in range(n):
        overrides = draw_hard(rng, t_end)
        overrides.append(f"solver.dt={accepted_dt(overrides)}")
        if max_iter is not None:
            overrides.append(f"solver.max_iter={max_iter}")
        res = []
        for halvings in (0, 4):
            cfg = simcore.load_config(overrides=overrides + [f"solver.max_halvings={halvings}"])
            began = time.process_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ds = simcore.run(cfg)
            res.append((ds, time.process_time() - began))
        (ds0, cpu0), (ds4, cpu4) = res
        flag0 = int((ds0["converged"].values[1:] == 0).sum())
        flag4 = int((ds4["converged"].values[1:] == 0).sum())
        retried = int(ds4.attrs["n_retried_steps"])
        totals += (flag0, retried, flag4)
        cpu += (cpu0, cpu4)
        m = cfg["model"]
        print(f"{m['mu']:5.3f} {m['omega0']:7.1f} {1e3 * m['clearance']:8.3f} "
              f"{m['n_balls']:5d} {m['e_N']:5.2f} {1e6 * cfg['solver']['dt']:6.2f} "
              f"{ds4['converged'].size - 1:6d} {flag0:8d} "
              f"{retried:8d} {flag4:8d} {int(ds4['halvings'].max()):5d} {cpu0:9.2f} "
              f"{cpu4:9.2f}")
    print(f"total: flagged without retries {totals[0]}, retried {totals[1]}, still flagged "
          f"{totals[2]}; CPU {cpu[0]:.1f} s without, {cpu[1]:.1f} s with retries")
    return int(totals[2])


def independent_energy(ds, cfg):
    """Kinetic + gravitational + cage-spring energy from the stored q and v [J] (not the
    kernel's own sum)."""
    datum_free, potential = independent_energy_parts(ds, cfg)
    return datum_free + potential


def independent_energy_scale(ds, cfg):
    """The energy audit's scale before each step [J], from :func:`independent_energy_parts`:
    the largest, over the rows up to the step, of |E| and of E without gravity's potential."""
    datum_free, potential = independent_energy_parts(ds, cfg)
    energy = datum_free + potential
    return np.maximum.accumulate(np.maximum(np.abs(energy), datum_free))[:-1]


def independent_energy_parts(ds, cfg):
    """Kinetic + cage-spring energy, and gravitational energy (datum: the origin), from the
    stored q and v [J]."""
    from simcore.model.mechanism import crank_slider

    model = crank_slider(cfg["model"])[0]
    mass = np.asarray(model.mass)
    inertia = np.asarray(model.inertia)
    if "q" not in ds:  # run files keep position and angle apart
        from simcore.io import generalized

        ds = generalized(ds)
    q, v = ds["q"].values, ds["v"].values
    kinetic = 0.5 * ((mass * (v[:, :, 0] ** 2 + v[:, :, 1] ** 2)).sum(axis=1)
                     + (inertia * v[:, :, 2] ** 2).sum(axis=1))
    potential = (mass * model.gravity * q[:, :, 1]).sum(axis=1)
    springs = np.zeros(q.shape[0])
    for bi, bj, geom in model.springs:  # ball centres, so the body points are the centres
        length = np.hypot(q[:, bj, 0] - q[:, bi, 0], q[:, bj, 1] - q[:, bi, 1])
        springs += 0.5 * geom[4] * (length - geom[6]) ** 2
    return kinetic + springs, potential


def regions(cfg):
    m = cfg["model"]
    names = [f"{m['drive']:8s} all"]
    if m["mu"] > 0.3:
        names.append(f"{m['drive']:8s} mu > 0.3")
    if m["omega0"] > 200:
        names.append(f"{m['drive']:8s} omega0 > 200")
    if m["clearance"] > 1e-3:
        names.append(f"{m['drive']:8s} clearance > 1 mm")
    if m["cage_damping"] == 0:
        names.append(f"{m['drive']:8s} no cage damping")
    return names


def main(n=300, t_end=0.1, seed=11, max_halvings=4, max_iter=None):
    import simcore
    from simcore.model.audit import ENERGY_FLOOR_J

    rng = np.random.default_rng(seed)
    table = {}
    silent_gain = silent_pen = 0
    slowest, slowest_run = 0.0, ""
    start = time.perf_counter()
    for index in range(n):
        cap = [] if max_iter is None else [f"solver.max_iter={max_iter}"]
        cfg = simcore.load_config(overrides=draw(rng, t_end) + cap
                                  + [f"solver.max_halvings={max_halvings}"])
        row = {"n": 0, "refused": 0, "defect": 0, "flagged": 0, "steps": 0, "worst": 0.0,
               "gain": 0, "pen": 0}
        outcome = {}
        began = time.process_time()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ds = simcore.run(cfg)
        except simcore.ConfigError:
            outcome["refused"] = 1
        else:
            conv = ds["converged"].values[1:] == 1
            h, tol = cfg["solver"]["dt"], cfg["solver"]["energy_tol"]
            energy = independent_energy(ds, cfg)
            rate = cfg["model"]["omega0"] if cfg["model"]["drive"] == "constant" else 0.0
            error = np.diff(energy) - ds["drive_torque"].values[1:] * rate * h
            scale = independent_energy_scale(ds, cfg)
            # rounding of the independent sum: a few ulps of the largest term
            gains = conv & (error > tol * scale + ENERGY_FLOOR_J + 1e-12 * scale)
            pens = conv & (ds["gap_N"].values[1:].min(axis=1) < -cfg["solver"]["tol"] * h)
            outcome = {"defect": int((~conv).any()), "flagged": int((~conv).sum()),
                       "steps": conv.size, "worst": float((~conv).mean()),
                       "gain": int(gains.any()), "pen": int(pens.any())}
            silent_gain += int(gains.sum())
            silent_pen += int(pens.sum())
            cpu = time.process_time() - began
            if cpu > slowest:
                slowest = cpu
                m = cfg["model"]
                slowest_run = (f": configuration {index}, {m['n_balls']} balls, clearance "
                               f"{m['clearance']:.3g} m, omega0 {m['omega0']:.4g} rad/s, "
                               f"{ds.attrs['n_retried_steps']} steps retried")
        for name in regions(cfg):
            r = table.setdefault(name, dict(row))
            r["n"] += 1
            for key, value in outcome.items():
                r[key] = max(r[key], value) if key == "worst" else r[key] + value
    cap = cfg["solver"]["max_iter"]
    print(f"{n} configurations, t_end = {t_end} s, seed {seed}, max_halvings {max_halvings}, "
          f"max_iter {cap}, {time.perf_counter() - start:.0f} s (slowest run {slowest:.1f} s "
          f"of CPU{slowest_run})")
    print(f"{'region':28s} {'runs':>5s} {'refused':>8s} {'defect':>7s} {'flagged':>9s} "
          f"{'worst':>6s} {'gain':>5s} {'pen':>4s}")
    for name in sorted(table):
        r = table[name]
        frac = r["flagged"] / r["steps"] if r["steps"] else 0.0
        print(f"{name:28s} {r['n']:5d} {r['refused']:8d} {r['defect']:7d} {frac:9.3%} "
              f"{r['worst']:6.1%} {r['gain']:5d} {r['pen']:4d}")
    print("columns: runs; refused by the dt limit; runs with a flagged step; flagged steps of "
          "the run steps; worst run's flagged fraction; runs with a silent energy gain; runs "
          "with a silent penetration")
    print(f"silent: {silent_gain} {silent_pen}")
    return silent_gain, silent_pen


if __name__ == "__main__":
    args = sys.argv[1:]
    if args and args[0] == "--hard":
        args = args[1:]
        hard_corners(int(args[0]) if args else 16, float(args[1]) if len(args) > 1 else 0.02,
                     int(args[2]) if len(args) > 2 else 5, int(args[3]) if len(args) > 3 else None)
        sys.exit(0)
    main(int(args[0]) if args else 300, float(args[1]) if len(args) > 1 else 0.1,
         int(args[2]) if len(args) > 2 else 11, int(args[3]) if len(args) > 3 else 4,
         int(args[4]) if len(args) > 4 else None)
