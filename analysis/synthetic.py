"""Synthetic run datasets with the layout of a run file, for tests, benchmarks and demos.

They are not simulations: the impulse histories are hand-built (isolated impacts, a persistent
contact train with impacts on top of it, noise), the kinematics is the ideal slider-crank plus a
small perturbation. Use them to exercise the analysis without the solver.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

__all__ = ["make_run_dataset", "make_pinch_dataset", "make_compliant_run", "PAPER_MODEL"]

PAPER_MODEL = {
    "model.clearance": 4.0e-4,
    "model.mu": 0.01,
    "model.omega0": 50.0,
    "model.e_N": 0.9,
    "model.e_T": 0.0,
    "model.n_balls": 8,
    "model.ball_radius": 0.0055,
    "model.ball_mass": 2.7e-3,
    "model.inner_radius": 0.033745,
    "model.youngs_modulus": 2.1e9,
    "model.poisson_ratio": 0.3,
    "model.crank_length": 0.11,
    "model.rod_length": 0.225,
    "solver.dt": 1.0e-4,
}


def _contact_coords(t, n_balls):
    """Coordinates ``time`` (``t`` [s]) and ``contact`` with its ``ball`` and ``race`` labels:
    balls 0..n_balls-1 on the inner race, then on the outer race (as a run file)."""
    return {
        "time": ("time", t, {"units": "s", "long_name": "time"}),
        "contact": np.arange(2 * n_balls),
        "ball": ("contact", np.tile(np.arange(n_balls), 2)),
        "race": ("contact", np.array(["inner"] * n_balls + ["outer"] * n_balls)),
    }


def _impulse_history(rng, n_steps, n_balls, lam_scale):
    """``Lambda_N`` [N s] and ``vn_pre`` [m/s] (time, contact) of :func:`make_run_dataset`:
    random isolated impacts on every contact, and on the first outer-race contact the
    hand-built history its docstring describes."""
    nc = 2 * n_balls
    lam = np.zeros((n_steps + 1, nc))
    vn_pre = np.zeros((n_steps + 1, nc))
    for c in range(nc):
        for k in rng.choice(np.arange(2, n_steps - 1, 4), size=min(5, n_steps // 8), replace=False):
            lam[k, c] = lam_scale * rng.uniform(0.05, 0.5)
            vn_pre[k, c] = -rng.uniform(0.01, 0.5)
    c0 = n_balls  # first outer-race contact: the hand-built history
    lam[:, c0] = 0.0
    vn_pre[:, c0] = 0.0
    if n_steps > 300:
        lam[50, c0] = lam_scale
        vn_pre[50, c0] = -0.3
        k = np.arange(100, 301)
        lam[k, c0] = 0.2 * lam_scale * (1.0 + 0.5 * np.sin(np.pi * (k - 100) / 200.0))
        vn_pre[k, c0] = -1e-5
        lam[150, c0] += 0.8 * lam_scale
        vn_pre[150, c0] = -0.2
        lam[220, c0] += 0.5 * lam_scale
        vn_pre[220, c0] = -1e-4  # no approach: kept, F_max missing
    return lam, vn_pre


# (93 lines: 30 are the docstring and 37 the one literal of the dataset's variables, a table
# read top to bottom; the impulse history is its own stage, _impulse_history)
def make_run_dataset(n_steps=600, n_balls=8, seed=0, clearance=4.0e-4, mu=0.01, omega0=50.0,
                     e_N=0.9, dt=1.0e-4, journal=True, lam_scale=1e-3, vn_free=True):
    """A synthetic run dataset with the layout of a run file (README, 'The run file').

    Parameters
    ----------
    n_steps : int
        Number of steps (``time`` has n_steps + 1 samples).
    n_balls : int
        Balls; ``contact`` has 2 n_balls entries.
    seed : int
        Random seed.
    clearance, mu, omega0, e_N : float
        Study parameters, stored as scalar coordinates (and as ``model.*`` attrs).
    dt : float
        Time step [s].
    journal : bool
        Include ``journal_x``, ``journal_y``.
    lam_scale : float
        Size of the impulses [N s].
    vn_free : bool
        Include ``vn_free`` (equal to ``vn_pre`` here); without it the analysis falls back to
        ``vn_pre``.

    Returns
    -------
    xarray.Dataset
        Lambda_N, Lambda_T, nu_N, gap_N, vn_pre, vn_post, q, v, crank_angle, slider_x, slider_v,
        energy, iterations, converged (+ journal_x, journal_y). On the first outer-race contact
        (index n_balls) there is an isolated impact at step 50 and a persistent train from step
        100 to 300 with impacts on it at steps 150 and 220.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n_steps + 1) * dt
    lam, vn_pre = _impulse_history(rng, n_steps, n_balls, lam_scale)
    vn_post = -e_N * vn_pre
    theta = omega0 * t
    L1, L2 = PAPER_MODEL["model.crank_length"], PAPER_MODEL["model.rod_length"]
    x_ideal = L1 * np.cos(theta) + np.sqrt(L2**2 - (L1 * np.sin(theta)) ** 2)
    bodies = ["crank", "rod", "slider"] + [f"ball{i}" for i in range(n_balls)]
    nb = len(bodies)
    q = rng.normal(0.0, 1e-3, (n_steps + 1, nb, 3))
    ds = xr.Dataset(
        {
            "Lambda_N": (("time", "contact"), lam, {"units": "N s", "long_name": "normal impulse"}),
            "Lambda_T": (("time", "contact"), 0.01 * lam,
                         {"units": "N s", "long_name": "tangential impulse"}),
            "nu_N": (("time", "contact"), np.zeros_like(lam),
                     {"units": "N s", "long_name": "position-correction multiplier"}),
            "gap_N": (("time", "contact"), np.where(lam > 0, 0.0, 1e-5),
                      {"units": "m", "long_name": "normal gap"}),
            "vn_pre": (("time", "contact"), vn_pre,
                       {"units": "m s-1", "long_name": "normal relative velocity before jump"}),
            "vn_post": (("time", "contact"), vn_post,
                        {"units": "m s-1", "long_name": "normal relative velocity after jump"}),
            "q": (("time", "body", "dof"), q, {"units": "", "long_name": "positions"}),
            "v": (("time", "body", "dof"), np.zeros_like(q), {"units": "", "long_name": "vel"}),
            "crank_angle": ("time", theta, {"units": "rad", "long_name": "crank angle"}),
            "slider_x": ("time", x_ideal + 1e-5 * np.sin(7 * theta),
                         {"units": "m", "long_name": "slider position"}),
            "slider_v": ("time", np.gradient(x_ideal, t) if t.size > 1 else 0 * t,
                         {"units": "m s-1", "long_name": "slider velocity"}),
            "energy": ("time", np.full(t.size, 1.0), {"units": "J", "long_name": "energy"}),
            "iterations": (("time", "stage"), np.ones((t.size, 3), dtype=np.int32),
                           {"units": "1", "long_name": "Newton iterations"}),
            "converged": ("time", np.ones(t.size, dtype=np.int8),
                          {"units": "1", "long_name": "converged"}),
        },
        coords={
            **_contact_coords(t, n_balls),
            "body": bodies,
            "dof": ["x", "y", "phi"],
            "stage": ["smooth", "position", "velocity"],
            "clearance": clearance,
            "mu": mu,
            "omega0": omega0,
            "e_N": e_N,
        },
    )
    if vn_free:
        ds["vn_free"] = (("time", "contact"), vn_pre.copy(),
                         {"units": "m s-1", "long_name": "normal relative velocity before the "
                                                         "jump of the step"})
    if journal:
        r = 0.8 * clearance * np.minimum(1.0, t / (t[-1] + dt) * 3)
        ds["journal_x"] = ("time", r * np.cos(3 * theta), {"units": "m", "long_name": "journal x"})
        ds["journal_y"] = ("time", r * np.sin(3 * theta), {"units": "m", "long_name": "journal y"})
    attrs = dict(PAPER_MODEL)
    attrs.update({"model.clearance": clearance, "model.mu": mu, "model.omega0": omega0,
                  "model.e_N": e_N, "model.n_balls": n_balls, "solver.dt": dt,
                  "title": "synthetic run (not a simulation)", "Conventions": "CF-1.8"})
    ds.attrs.update(attrs)
    return ds


def make_pinch_dataset(v_inner=0.3, v_outer=0.2, m_crank=2.0, m_rod=3.0, e_N=0.9, dt=1e-4,
                       n_steps=40, step=20, n_balls=3, youngs_modulus=2.1e9, static_force=0.0,
                       second_step_offset=0):
    """A run dataset with one ball pinched between the two races (and nothing else).

    The inner race (mass ``m_crank``) and the outer race (mass ``m_rod``) approach each other
    along the line of ball 0: ball 0 sees the inner race approach at ``v_inner`` and the outer
    race at ``v_outer`` (``vn_free`` = -v on its two contacts), so the races' relative approach
    speed is V = v_inner + v_outer. The ball's mass is neglected: the pair of contacts takes the
    impulse of two bodies of reduced mass μ = m_crank m_rod / (m_crank + m_rod) with Newton's
    restitution, Λ = (1 + e_N) μ V, on both contacts in the same step (or, with
    ``second_step_offset`` = ±1, the outer one step later or earlier). With ``static_force`` > 0
    both contacts also carry F_s h in every step from 5 to n_steps - 5 (the ball is loaded).

    Returns
    -------
    xarray.Dataset
        Lambda_N, vn_pre, vn_free, vn_post, converged on (time, contact) with the paper's model
        attributes; attrs ``pinch_reduced_mass`` [kg], ``pinch_speed`` [m/s], ``pinch_impulse``
        [N s].
    """
    nc = 2 * n_balls
    t = np.arange(n_steps + 1) * dt
    lam = np.zeros((n_steps + 1, nc))
    vn = np.zeros((n_steps + 1, nc))
    mu = m_crank * m_rod / (m_crank + m_rod)
    V = v_inner + v_outer
    L = (1.0 + e_N) * mu * V
    inner, outer = 0, n_balls
    if static_force > 0:
        lam[5:n_steps - 4, inner] = static_force * dt
        lam[5:n_steps - 4, outer] = static_force * dt
    lam[step, inner] += L
    lam[step + second_step_offset, outer] += L
    # the approach velocities before the jump hold in the step(s) of the pinch
    k0, k1 = min(step, step + second_step_offset), max(step, step + second_step_offset)
    vn[k0:k1 + 1, inner] = -v_inner
    vn[k0:k1 + 1, outer] = -v_outer
    tc = ("time", "contact")
    ds = xr.Dataset(
        {
            "Lambda_N": (tc, lam, {"units": "N s", "long_name": "normal impulse"}),
            "vn_pre": (tc, vn.copy(), {"units": "m s-1", "long_name": "vn at step start"}),
            "vn_free": (tc, vn, {"units": "m s-1", "long_name": "vn before the jump"}),
            "vn_post": (tc, -e_N * vn, {"units": "m s-1", "long_name": "vn after the jump"}),
            "converged": ("time", np.ones(t.size, dtype=np.int8),
                          {"units": "1", "long_name": "converged"}),
        },
        coords={
            **_contact_coords(t, n_balls),
            "clearance": 4e-4, "mu": 0.01, "omega0": 50.0, "e_N": e_N,
        },
    )
    attrs = dict(PAPER_MODEL)
    attrs.update({"model.e_N": e_N, "model.n_balls": n_balls, "solver.dt": dt,
                  "model.youngs_modulus": youngs_modulus,
                  "title": "synthetic pinch (not a simulation)",
                  "pinch_reduced_mass": mu, "pinch_speed": V, "pinch_impulse": L})
    ds.attrs.update(attrs)
    return ds


def make_compliant_run(force, output_dt=1.0e-4, omega0=50.0, clearance=4.0e-4, mu=0.01,
                       e_N=0.9, youngs_modulus=2.1e9, failed=False):
    """A compliant run dataset around a given contact-force history (not a simulation).

    Parameters
    ----------
    force : array_like
        ``F_N`` (time, contact) [N]: the largest contact force of each output interval, with
        ``contact`` = 2 n_balls (balls 0..n-1 on the inner race, then on the outer race).
    output_dt : float
        Output interval [s]; sample k is at k output_dt.
    omega0 : float
        Crank speed of the constant drive [rad/s]: ``crank_angle`` = omega0 t.
    clearance, mu, e_N : float
        Study parameters (length-1 coordinates, as a run file) [m], [-], [-].
    youngs_modulus : float
        [Pa], for the Hertz stresses the analysis computes.
    failed : bool
        Return the marker of a failed compliant run instead.

    Returns
    -------
    xarray.Dataset
        ``F_N``, ``Lambda_N`` (F_N times the interval), ``crank_angle``, ``iterations``,
        ``converged``; attributes of the paper's model with ``model.contact_model`` =
        ``compliant`` and ``output_interval_s``.
    """
    force = np.asarray(force, dtype=float)
    n_samples, nc = force.shape
    n_balls = nc // 2
    t = np.arange(n_samples) * output_dt
    attrs = dict(PAPER_MODEL)
    attrs.update({"model.clearance": clearance, "model.mu": mu, "model.omega0": omega0,
                  "model.e_N": e_N, "model.n_balls": n_balls,
                  "model.youngs_modulus": youngs_modulus, "model.contact_model": "compliant",
                  "model.drive": "constant", "contact_model": "compliant",
                  "solver.dt": output_dt / 50.0, "solver.output_dt": output_dt,
                  "output_interval_s": output_dt, "wall_time_s": 1.0,
                  "title": "synthetic compliant run (not a simulation)"})
    coords = {name: ((name,), [value]) for name, value in
              (("clearance", clearance), ("mu", mu), ("omega0", omega0), ("e_N", e_N))}
    if failed:
        return xr.Dataset(coords=coords, attrs=dict(attrs, failed=1, error="synthetic"))
    ds = xr.Dataset(
        {
            "F_N": (("time", "contact"), force, {"units": "N", "long_name": "contact force"}),
            "Lambda_N": (("time", "contact"), force * output_dt,
                         {"units": "N s", "long_name": "impulse of the interval"}),
            "crank_angle": ("time", omega0 * t, {"units": "rad", "long_name": "crank angle"}),
            "iterations": (("time", "stage"), np.ones((n_samples, 3), dtype=np.int32),
                           {"units": "1", "long_name": "Newton iterations"}),
            "converged": ("time", np.ones(n_samples, dtype=np.int8),
                          {"units": "1", "long_name": "converged"}),
        },
        coords={**_contact_coords(t, n_balls),
                "stage": ["smooth", "position", "velocity"], **coords},
        attrs=attrs)
    return ds
