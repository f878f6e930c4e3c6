"""Limits known before a run: the step size against the model's fastest time scales, and the
memory the run's arrays will take.

Both checks run when the model is built, before any array of the time loop is allocated, so a
run that cannot be resolved or would not fit in memory is refused in one line naming the key
(``solver.dt``, ``solver.t_end``) and the limit.

Step size
---------
The smooth forces are integrated by the implicit generalized-alpha scheme: it does not blow up
on a linear spring whatever the step, but it only *resolves* an oscillation whose period spans a
few steps. A cage spring that the step cannot resolve, combined with the rotating spring axes
and the impacts, turns a 33.6 J run into 467 kJ in 22 steps (docs/reliability.md, section 2). The
fastest spring/mass frequency is bounded from the model's springs and masses (Gershgorin's
bound of ``M^-1/2 K M^-1/2``, translational part)::

    omega_max^2 = max_i  sum_{springs s at body i}  k_s (1/m_i + 1/sqrt(m_i m_j))

which is exact for the ring of n equal balls and n equal cage springs of the bearing
(omega_max = 2 sqrt(k/m_ball), the neighbouring balls moving against each other). The same
bound with the damper coefficients gives the damping rate ``gamma_max`` (= 4 c/m_ball) of that
mode, and its damping ratio ``zeta = gamma_max / (2 omega_max)`` (= c / sqrt(k m_ball)).

- An oscillating mode (zeta < 1) needs ``omega_max * dt <= OMEGA_DT_MAX`` (= 2, the step at
  which an explicit central-difference scheme would become unstable: the period spans at least
  pi steps). Its damped frequency ``omega_max sqrt(1 - zeta^2)`` is the one compared.
- An overdamped mode (zeta >= 1) does not oscillate: its fast root (rate ~ gamma_max) decays
  in one step under the scheme's numerical damping, its slow root (rate ~ k/c) is slow. No
  limit, the paper's case (k = 1e5 N/m, c = 1e3 N s/m, zeta = 61) is of this kind.

Rigid contacts have no time scale of their own: an impact is a velocity jump, resolved by the
impact law at any step size. What the step must still resolve there is the motion between
impacts, i.e. the spring/mass modes above; the energy audit (:mod:`simcore.model.audit`) catches any
step that creates energy anyway.

Memory
------
``(output rows) x (values stored per row) x 8 bytes``, one row per ``solver.output_dt`` (per
step where it is null), with the values per row counted from the model (positions and
velocities of every body, seven arrays per contact and nine for the compliant model, energy,
energy error and its tolerance, drive torque, time, iterations, two flags). Refused above
``solver.max_memory_gb``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from . import ConfigError

#: largest omega * dt of an oscillating spring/mass mode (see the module docstring)
OMEGA_DT_MAX = 2.0

#: shortest step [s] a cage must be resolvable with: a cage mode that needs less is refused
#: naming the cage's keys (a run of 0.3 s at 1e-9 s would be 3e8 steps, beyond any memory)
MIN_RESOLVABLE_DT = 1e-9

#: largest c h / m of a cage damper on a ball: the step's Newton matrix holds M / h + c, and
#: the masses vanish from it in double precision near c h / m = 1e13 (the paper's case fails
#: from cage_damping = 1e12 N s/m at dt = 1e-4 s, c h / m = 3.7e13; runs at 1e11, 3.7e12)
MAX_DAMPING_RATIO = 1e9


@dataclass
class SpringScales:
    """Fastest spring/mass time scales of a model."""

    omega_max: float   # bound of the highest spring/mass angular frequency [rad/s]
    gamma_max: float   # bound of the highest damper/mass rate [1/s]

    @property
    def zeta(self) -> float:
        """Damping ratio of the fastest mode [-] (inf without springs)."""
        if self.omega_max == 0.0:
            return math.inf
        return self.gamma_max / (2.0 * self.omega_max)

    @property
    def omega_damped(self) -> float:
        """Damped angular frequency of the fastest mode [rad/s] (0 when overdamped)."""
        z = self.zeta
        return self.omega_max * math.sqrt(1.0 - z * z) if z < 1.0 else 0.0

    @property
    def dt_limit(self) -> float:
        """Largest step that resolves the fastest oscillating mode [s] (inf if none)."""
        wd = self.omega_damped
        return OMEGA_DT_MAX / wd if wd > 0.0 else math.inf


def spring_scales(model) -> SpringScales:
    """Bound the fastest spring/mass frequency and damping rate of a :class:`simcore.model.Model`.

    Parameters
    ----------
    model : simcore.model.Model
        A built model (bodies and springs added).

    Returns
    -------
    SpringScales
    """
    mass = np.asarray(model.mass, dtype=float)
    stiff = np.zeros(mass.size)
    damp = np.zeros(mass.size)
    with np.errstate(over="ignore", divide="ignore"):  # extreme inputs give inf, not an error
        for bi, bj, geom in model.springs:
            k, c = float(geom[4]), float(geom[5])
            for a, b in ((bi, bj), (bj, bi)):
                if a < 0:
                    continue
                w = np.float64(1.0) / mass[a] + (
                    np.float64(1.0) / np.sqrt(mass[a]) / np.sqrt(mass[b]) if b >= 0 else 0.0)
                stiff[a] += k * w
                damp[a] += c * w
    if mass.size == 0:
        return SpringScales(0.0, 0.0)
    return SpringScales(math.sqrt(float(stiff.max())), float(damp.max()))


def check_step_size(model, dt: float, policy: str = "error", key: str = "solver.dt"
                    ) -> str | None:
    """Refuse (or warn about) a step that cannot resolve the model's fastest spring mode.

    Parameters
    ----------
    model : simcore.model.Model
    dt : float
        Time step [s]: the fixed step, or the smallest an adaptive run can take.
    policy : {"error", "warn"}
        ``solver.on_unresolved_dt``.
    key : str
        The configuration key of ``dt`` (``solver.dt``, or ``solver.dt_min`` with adaptive
        steps), named in the message.

    Returns
    -------
    str or None
        The message, when the step is too large and the policy is ``"warn"``.

    Raises
    ------
    ConfigError
        One line naming ``key`` and the limit (policy ``"error"``).
    """
    scales = spring_scales(model)
    if dt <= scales.dt_limit:
        return None
    if not scales.dt_limit >= MIN_RESOLVABLE_DT:
        _refuse_cage(model, scales)
    why = (f"<= {scales.dt_limit:.3g} s, to resolve the fastest spring/mass mode (omega = "
           f"{scales.omega_damped:.4g} rad/s, damping ratio {scales.zeta:.3g}; omega * dt <= "
           f"{OMEGA_DT_MAX:g})")
    if policy == "error":
        raise ConfigError(f"{key}: {dt!r} is not allowed; allowed: {why}; lower {key} (or "
                          "model.cage_stiffness, or raise model.cage_damping), or set "
                          "solver.on_unresolved_dt=warn")
    msg = (f"{key}: {dt!r} is above the limit {why}; running anyway "
           "(solver.on_unresolved_dt=warn), the energy audit watches every step")
    warnings.warn(msg, RuntimeWarning, stacklevel=2)
    return msg


def _ball_cage(model) -> tuple[float, float, float]:
    """(stiffness [N/m], damping [N s/m], ball mass [kg]) of the stiffest cage spring of the
    crank-slider (its springs are the cage's, between balls)."""
    bi, bj, geom = max(model.springs, key=lambda s: float(s[2][4]))
    return float(geom[4]), float(geom[5]), float(model.mass[bi])


def _refuse_cage(model, scales: SpringScales) -> None:
    """The cage's fastest mode needs a step below :data:`MIN_RESOLVABLE_DT`: refused naming
    the cage's keys, not the step."""
    k, _, m = _ball_cage(model)
    k_max = m * (OMEGA_DT_MAX / MIN_RESOLVABLE_DT) ** 2 / 4.0
    raise ConfigError(
        f"model.cage_stiffness: {k!r} is not allowed with model.ball_mass = {m!r}: the cage's "
        f"fastest spring/mass mode (omega = {scales.omega_damped:.3g} rad/s) needs a step "
        f"below {MIN_RESOLVABLE_DT:g} s; allowed: cage_stiffness <= {k_max:.3g} N/m for this "
        "ball mass (4 k / m_ball <= (2 / 1e-9 s)^2), or a cage damping that makes the mode "
        "overdamped, cage_damping >= sqrt(cage_stiffness x ball_mass)")


def check_cage_damping(model, dt: float) -> None:
    """Refuse a cage damper that the step's Newton matrix cannot hold beside the balls' masses:
    c dt / m_ball above :data:`MAX_DAMPING_RATIO`.

    Raises
    ------
    ConfigError
        One line naming ``model.cage_damping``, the ratio and the largest damping allowed.
    """
    if not model.springs:
        return
    ratios = [float(geom[5]) * dt / min(float(model.mass[b]) for b in (bi, bj) if b >= 0)
              for bi, bj, geom in model.springs]
    if not max(ratios) > MAX_DAMPING_RATIO:
        return
    _, c, m = max(((float(g[4]), float(g[5]), float(model.mass[bi])) for bi, _, g in
                   model.springs), key=lambda t: t[1])
    raise ConfigError(
        f"model.cage_damping: {c!r} is not allowed with solver.dt = {dt!r} s and "
        f"model.ball_mass = {m!r} kg; allowed: cage_damping x solver.dt / ball_mass <= "
        f"{MAX_DAMPING_RATIO:g}, here cage_damping <= {MAX_DAMPING_RATIO * m / dt:.3g} N s/m (a "
        "damper that much stronger than a ball's inertia leaves the step's Newton matrix "
        "singular in double precision)")


def values_per_step(model=None, n_bodies=None, n_contacts=None, compliant=False) -> int:
    """Numbers stored per output row by :meth:`simcore.model.Model.simulate` [-], from a model
    or from its numbers of bodies and contacts; ``compliant``: with the compliant model's
    forces."""
    if model is not None:
        n_bodies, n_contacts = len(model.mass), len(model.contacts)
    ndof = 3 * n_bodies
    # q, v; per contact Lambda_N, Lambda_T, nu_N, gap_N, vn_pre, vn_post, vn_free (compliant:
    # and F_N, F_T); time, energy, energy_error and its tolerance, drive torque; 3 iteration
    # counts (int64); the converged and halvings flags (int8, counted as one each)
    per_contact = 9 if compliant else 7
    return 2 * ndof + per_contact * n_contacts + 5 + 3 + 2


def memory_estimate(model, dt: float, t_end: float, every: int = 1,
                    compliant: bool = False) -> float:
    """Bytes of the arrays of a run: (steps // every + 1) rows x values per row x 8 [B], with
    ``every`` steps per output row (a float: inf for a step too small to count the steps)."""
    with np.errstate(over="ignore"):
        n_steps = np.round(np.float64(t_end) / np.float64(dt))
    rows = np.floor(n_steps / every) + 1.0
    return float(rows * values_per_step(model, compliant=compliant) * 8.0)


def check_memory_of_config(cfg: dict) -> int:
    """:func:`check_memory` for the crank-slider of a validated configuration, without building
    the model: 3 + n_balls bodies, 2 n_balls contacts."""
    n = int(cfg["model"]["n_balls"])
    guards = n + 1 if cfg["model"].get("guard_contacts", True) else 0
    return check_memory(_Counts(3 + n, 2 * n + guards), cfg["solver"]["dt"],
                        cfg["solver"]["t_end"], cfg["solver"]["max_memory_gb"], *_rows_of(cfg))


def _rows_of(cfg: dict) -> tuple[int, bool]:
    """Steps per output row and whether the run is compliant (:func:`memory_estimate`)."""
    from . import output_every

    return output_every(cfg), cfg["model"].get("contact_model", "nonsmooth") == "compliant"


class _Counts:
    """Stand-in with the sizes :func:`values_per_step` reads."""

    def __init__(self, n_bodies, n_contacts):
        self.mass = [0.0] * n_bodies
        self.contacts = [None] * n_contacts


class _CageRing:
    """Stand-in of the crank-slider for :func:`spring_scales`: its springs are the cage
    springs between neighbouring balls (bodies 3 .. 3 + n - 1), see
    :func:`simcore.model.mechanism.crank_slider`."""

    def __init__(self, model: dict):
        n = int(model["n_balls"])
        self.mass = [1.0, 1.0, 1.0] + [float(model["ball_mass"])] * n
        geom = (0.0, 0.0, 0.0, 0.0, float(model["cage_stiffness"]), float(model["cage_damping"]),
                0.0)
        self.springs = [(3 + k, 3 + (k + 1) % n, geom) for k in range(n)]


def check_run_of_config(cfg: dict) -> list[str]:
    """:func:`check_run` for the crank-slider of a validated configuration without building
    the model, for a command line that answers at once."""
    check_memory_of_config(cfg)
    cage = _CageRing(cfg["model"])
    check_cage_damping(cage, cfg["solver"]["dt"])  # c h / m is largest at the largest step
    dt, key = limiting_step(cfg)
    msgs = [check_step_size(cage, dt, cfg["solver"]["on_unresolved_dt"], key),
            check_contact_step(cfg), check_unused_restitution(cfg)]
    return [m for m in msgs if m]


def limiting_step(cfg: dict) -> tuple[float, str]:
    """The step the stability limits are checked against, and its key: the fixed step
    ``solver.dt``, or with adaptive steps the smallest one they can take, ``solver.dt_min``
    (the error control shortens the step wherever a spring mode or a contact needs it)."""
    solver = cfg["solver"]
    if solver.get("adaptive", False):
        return float(solver["dt_min"]), "solver.dt_min"
    return float(solver["dt"]), "solver.dt"


def check_memory(model, dt: float, t_end: float, max_gb: float, every: int = 1,
                 compliant: bool = False) -> int:
    """Refuse a run whose arrays would take more than ``max_gb`` GB (1e9 bytes)
    (:func:`memory_estimate`, ``every`` steps per output row).

    Returns
    -------
    int
        The estimate [B].

    Raises
    ------
    ConfigError
        One line naming ``solver.t_end`` / ``solver.dt``, the estimate and the limit.
    """
    need = memory_estimate(model, dt, t_end, every, compliant)
    if not need <= max_gb * 1e9:
        per_row = values_per_step(model, compliant=compliant)
        rows = need / (8.0 * per_row)
        raise ConfigError(
            f"solver.t_end: {t_end!r} with solver.dt = {dt!r} is not allowed: {rows:.4g} "
            f"output rows x {per_row} values x 8 B = {need / 1e9:.3g} GB of arrays; "
            f"allowed: at most solver.max_memory_gb = {max_gb:g} GB (shorten solver.t_end, raise "
            "solver.dt or solver.max_memory_gb)")
    return need


def check_run(cfg: dict, model=None) -> list[str]:
    """Both checks for a validated configuration of the crank-slider.

    Parameters
    ----------
    cfg : dict
        Validated configuration.
    model : simcore.model.Model, optional
        The built model; built here from ``cfg["model"]`` if not given (cheap: no arrays of
        the time loop).

    Returns
    -------
    list of str
        Warnings given (policy ``"warn"``).

    Raises
    ------
    ConfigError
        One line, before any allocation.
    """
    if model is None:
        from ..model.mechanism import crank_slider

        model = crank_slider(cfg["model"])[0]
    solver = cfg["solver"]
    check_memory(model, solver["dt"], solver["t_end"], solver["max_memory_gb"], *_rows_of(cfg))
    check_cage_damping(model, solver["dt"])
    dt, key = limiting_step(cfg)
    msgs = [check_step_size(model, dt, solver["on_unresolved_dt"], key),
            check_contact_step(cfg), check_unused_restitution(cfg)]
    return [m for m in msgs if m]


def check_unused_restitution(cfg: dict) -> str | None:
    """Warn that ``model.e_T`` (not 0) has no effect on a compliant run: its friction is
    regularised Coulomb friction, with no tangential compliance to restitute, so a compliant
    twin is the same for every ``e_T`` (docs/compliant.md, "Friction").

    Returns
    -------
    str or None
        The message, where the warning is given.
    """
    model = cfg["model"]
    if model.get("contact_model", "nonsmooth") != "compliant" or model.get("e_T", 0.0) == 0.0:
        return None
    msg = ("model.e_T: not 0 but has no effect on the compliant model (regularised Coulomb "
           "friction has no tangential restitution); its runs are the same for every e_T")
    warnings.warn(msg, RuntimeWarning, stacklevel=2)
    return msg


#: fewest steps a compliant contact must last (its Hertz contact time over dt)
MIN_CONTACT_STEPS = 5.0


def hertz_contact_time(model: dict, speed: float | None = None) -> float:
    """Shortest Hertz contact time of a ball on a race in the crank-slider of ``model`` [s].

    An undamped Hertz impact of mass m at speed v on a contact of stiffness K lasts
    2.94 δ_max / v with δ_max = (5 m v² / (4 K))^(2/5). Here m is the ball mass, K the stiffer
    of the two races (the concave outer race: R = r_B r_C/(r_C − r_B); the inner race:
    R = r_A r_B/(r_A + r_B); K = (4/3) E* sqrt(R), both bodies of the same material; with
    ``model.contact_geometry`` groove the elliptical K of each race's groove) and v the
    speed of the crank pin, |omega0| L_crank, at least 1 m/s: a ball hits a race at about the
    speed the pin carries it, and a faster impact is a shorter one (t ∝ v^(-1/5)).

    Parameters
    ----------
    model : dict
        The validated ``model`` section.
    speed : float, optional
        Impact speed [m/s] to use instead of the crank pin's (e.g. an impact's approach speed,
        for the step of a compliant zoom on it); floored at 1e-3 m/s.
    """
    from ..kernels.hertz import hertz_impact_time
    from ..model.bearing import BearingGeometry, race_grooves
    from ..model.hertz import hertz_stiffness

    E, nu = float(model["youngs_modulus"]), float(model["poisson_ratio"])
    geometry = BearingGeometry.from_model(model)
    r_a, r_b, r_c = geometry.inner_radius, geometry.ball_radius, geometry.outer_radius
    groove_in, groove_out = race_grooves(model) or (None, None)
    stiffness = max(hertz_stiffness("outside", r_a, r_b, E, nu, groove_in),
                    hertz_stiffness("inside", r_c, r_b, E, nu, groove_out))
    if speed is None:
        speed = max(abs(float(model["omega0"])) * float(model["crank_length"]), 1.0)
    speed = max(float(speed), 1e-3)
    return hertz_impact_time.py_func(1.0 / float(model["ball_mass"]), stiffness, speed)


def check_contact_step(cfg: dict) -> str | None:
    """Refuse (or warn about) a compliant run whose step cannot resolve a contact.

    Only for ``model.contact_model = compliant`` (a nonsmooth contact has no duration). The
    step (with adaptive steps the smallest, :func:`limiting_step`) must be at most
    1/:data:`MIN_CONTACT_STEPS` of :func:`hertz_contact_time`.

    Returns
    -------
    str or None
        The message, when the step is too large and ``solver.on_unresolved_dt`` is ``"warn"``.

    Raises
    ------
    ConfigError
        One line naming ``solver.dt`` and the limit (policy ``"error"``).
    """
    if cfg["model"].get("contact_model", "nonsmooth") != "compliant":
        return None
    dt, key = limiting_step(cfg)
    t_contact = hertz_contact_time(cfg["model"])
    limit = t_contact / MIN_CONTACT_STEPS
    if dt <= limit:
        return None
    why = (f"<= {limit:.3g} s, to resolve a compliant contact in {MIN_CONTACT_STEPS:g} steps or "
           f"more (Hertz contact time of a ball hitting a race at the crank pin's speed: "
           f"{t_contact:.3g} s with model.youngs_modulus = {cfg['model']['youngs_modulus']:g})")
    if cfg["solver"]["on_unresolved_dt"] == "error":
        raise ConfigError(f"{key}: {dt!r} is not allowed; allowed: {why}; lower {key}, "
                          "or set solver.on_unresolved_dt=warn")
    msg = (f"{key}: {dt!r} is above the limit {why}; running anyway "
           "(solver.on_unresolved_dt=warn), the energy audit watches every step")
    warnings.warn(msg, RuntimeWarning, stacklevel=2)
    return msg
