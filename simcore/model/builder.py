"""A small planar multibody model builder and the Python driver of the time loop.

The builder collects bodies, joints, spring-dampers and contacts, checks their inputs and hands
flat arrays (one :class:`simcore.kernels.ModelArrays` bundle) to the Numba kernels of
:mod:`simcore.kernels`. Scenes (the crank-slider bearing,
the validation cases) are builder functions on top of it, see :mod:`simcore.model.mechanism`.
"""

from __future__ import annotations

import sys
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..startup.numba_cache import preload_scipy_blas

preload_scipy_blas()  # before Numba's first kernel call: 0.2 s less in a new process

from .. import kernels as nb  # noqa: E402
from .audit import EnergyAudit  # noqa: E402

CONTACT_MODELS = ("nonsmooth", "compliant")
DAMPING_LAWS = ("flores", "hunt_crossley", "lankarani_nikravesh")

CONTACT_KINDS = {"plane": nb.CONTACT_PLANE, "outside": nb.CONTACT_OUTSIDE,
                 "inside": nb.CONTACT_INSIDE}


def damping_factor(e_N: float, law: str = "flores") -> float:
    """Hysteresis damping factor chi of F = K delta^1.5 (1 + chi delta_dot / v_pre) [-].

    flores: 8 (1 - e) / (5 e); hunt_crossley: 3 (1 - e) / 2; lankarani_nikravesh:
    3 (1 - e^2) / 4. The Flores law is undefined for e = 0 (refused)."""
    e = float(e_N)
    if law == "flores":
        if e <= 0.0:
            raise ValueError("model.e_N: 0 is not allowed with model.damping_law = flores "
                             "(chi = 8 (1 - e) / (5 e) is infinite); allowed: (0, 1], or "
                             "damping_law hunt_crossley or lankarani_nikravesh")
        return 8.0 * (1.0 - e) / (5.0 * e)
    if law == "hunt_crossley":
        return 1.5 * (1.0 - e)
    if law == "lankarani_nikravesh":
        return 0.75 * (1.0 - e * e)
    raise ValueError(f"model.damping_law: {law!r} is not allowed; allowed: "
                     + ", ".join(DAMPING_LAWS))


def hertz_stiffness(kind: str, radius_a: float, radius_b: float, youngs_modulus: float,
                    poisson_ratio: float) -> float:
    """Hertz stiffness K = (4/3) E* sqrt(R_eff) [N m^-1.5] of a contact element, both bodies of
    the same material: E* = E / (2 (1 - nu^2)); R_eff = r_b on a plane, r_a r_b / (r_a + r_b)
    for a sphere on a sphere (convex), r_a r_b / (r_a - r_b) for a sphere inside a ring of
    radius r_a (concave)."""
    e_star = youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))
    if kind == "plane":
        r_eff = radius_b
    elif kind == "outside":
        r_eff = radius_a * radius_b / (radius_a + radius_b)
    elif kind == "inside":
        r_eff = radius_a * radius_b / (radius_a - radius_b)
    else:
        raise ValueError(f"contact kind {kind!r} is not allowed; allowed: plane, outside, "
                         "inside")
    return 4.0 / 3.0 * e_star * np.sqrt(r_eff)


class SolverError(RuntimeError):
    """A sub-problem of a step did not converge (with ``on_nonconvergence = "error"``)."""


def _finite(name, value, positive=False, nonneg=False):
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"{name}: {value!r} is not allowed; allowed: a finite number")
    if positive and value <= 0.0:
        raise ValueError(f"{name}: {value!r} is not allowed; allowed: > 0")
    if nonneg and value < 0.0:
        raise ValueError(f"{name}: {value!r} is not allowed; allowed: >= 0")
    return value


@dataclass
class Trajectory:
    """Plain-array result of :meth:`Model.simulate` (one row per output time, t0 included).

    Nonsmooth runs: one row per step, the impulses of the step's velocity jump. Compliant runs:
    one row per output interval; ``lambda_N``/``lambda_T`` are the impulses over the interval,
    ``F_N`` the largest normal force in it and ``F_T`` the friction force at that peak,
    ``gap_N`` the smallest gap in it, ``vn_pre``/``vn_post`` the normal velocity at its start
    and end (``vn_free`` = ``vn_post``: nothing jumps), ``nu_N`` zero."""

    time: np.ndarray
    q: np.ndarray
    v: np.ndarray
    lambda_N: np.ndarray
    lambda_T: np.ndarray
    nu_N: np.ndarray
    gap_N: np.ndarray
    vn_pre: np.ndarray
    vn_post: np.ndarray
    vn_free: np.ndarray
    energy: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    drive_torque: np.ndarray
    F_N: np.ndarray | None = None
    F_T: np.ndarray | None = None
    contact_model: str = "nonsmooth"
    wall_time_s: float = 0.0
    first_unconverged_step: int = -1
    extras: dict = field(default_factory=dict)


class _ReleaseWatch:
    """The early stop of a compliant run on groups of contacts (``simulate(...,
    watch_contacts=...)``): group g's episode starts at the first output row where one of its
    onset contacts carries a normal force and ends at the first later row where none of its
    contacts carries one. Fed the force rows chunk by chunk; says when every episode ended."""

    def __init__(self, groups, onset, nc):
        groups = np.atleast_2d(np.asarray(groups, dtype=bool))
        onset = groups if onset is None else np.atleast_2d(np.asarray(onset, dtype=bool))
        if groups.shape[1] != nc or onset.shape != groups.shape:
            raise ValueError(f"watch_contacts: shape {groups.shape} is not allowed; allowed: "
                             f"(nc,) or (groups, nc) booleans with nc = {nc}, watch_onset the "
                             "same shape")
        self.groups = groups
        self.onset = onset
        self.onset_row = np.full(groups.shape[0], -1)
        self.done = ~groups.any(axis=1)  # an empty group has nothing to wait for

    def released(self, F_N, row0, row1) -> bool:
        """Take the rows ``row0 .. row1 - 1`` of ``F_N`` (rows, nc); True once every group's
        episode has ended."""
        F = np.asarray(F_N[row0:row1]) > 0.0
        for g in np.flatnonzero(~self.done):
            if self.onset_row[g] < 0:
                on = F[:, self.onset[g]]
                if row0 == 0 and on.shape[0] > 1:
                    on[0] &= on[1]  # a force at the first row alone is no onset
                first = np.flatnonzero(on.any(axis=1))
                if first.size == 0:
                    continue
                self.onset_row[g] = row0 + first[0]
            start = self.onset_row[g] - row0 + 1  # rows after the onset
            free = np.flatnonzero(~F[max(start, 0):, self.groups[g]].any(axis=1))
            if free.size:
                self.done[g] = True
        return bool(self.done.all())


class Model:
    """Planar rigid bodies (x, y, phi) with joints, spring-dampers and frictional contacts.

    Examples
    --------
    >>> m = Model(gravity=9.81)
    >>> ball = m.add_body("ball", mass=1.0, inertia=0.004, q0=(0.0, 1.0, 0.0))
    >>> m.add_contact("plane", -1, (0.0, 0.0), np.pi / 2, ball, (0.0, 0.0), 0.1,
    ...               mu=0.0, e_N=0.5)
    0
    """

    def __init__(self, gravity: float = 9.81, youngs_modulus: float = 2.1e11,
                 poisson_ratio: float = 0.3):
        self.gravity = _finite("gravity", gravity, nonneg=True)
        self.youngs_modulus = _finite("model.youngs_modulus", youngs_modulus, positive=True)
        self.poisson_ratio = _finite("model.poisson_ratio", poisson_ratio, nonneg=True)
        if self.poisson_ratio >= 0.5:
            raise ValueError(f"model.poisson_ratio: {poisson_ratio!r} is not allowed; "
                             "allowed: in [0, 0.5)")
        self.body_names: list[str] = []
        self.mass: list[float] = []
        self.inertia: list[float] = []
        self.q0: list[tuple[float, float, float]] = []
        self.v0: list[tuple[float, float, float]] = []
        self.joints: list[tuple[int, int, int, tuple]] = []
        self.springs: list[tuple[int, int, tuple]] = []
        self.contacts: list[tuple[int, int, int, tuple, tuple]] = []
        self.contact_names: list[str] = []

    # -- elements ----------------------------------------------------------------------------
    def add_body(self, name, mass, inertia, q0=(0.0, 0.0, 0.0), v0=(0.0, 0.0, 0.0)) -> int:
        """Add a rigid body.

        Parameters
        ----------
        name : str
            Body name (unique).
        mass : float
            Mass [kg], > 0.
        inertia : float
            Moment of inertia about the centre of mass, z axis [kg m^2], > 0.
        q0, v0 : tuple of 3 floats
            Initial (x [m], y [m], phi [rad]) and (vx [m/s], vy [m/s], omega [rad/s]).

        Returns
        -------
        int
            Body index.
        """
        if name in self.body_names:
            raise ValueError(f"body name {name!r} is used twice")
        self.body_names.append(str(name))
        self.mass.append(_finite(f"{name}.mass", mass, positive=True))
        self.inertia.append(_finite(f"{name}.inertia", inertia, positive=True))
        self.q0.append(tuple(_finite(f"{name}.q0", x) for x in q0))
        self.v0.append(tuple(_finite(f"{name}.v0", x) for x in v0))
        return len(self.body_names) - 1

    def _check_body(self, b, allow_ground=True):
        lo = -1 if allow_ground else 0
        if not (lo <= int(b) < len(self.body_names)):
            raise ValueError(f"body index {b} does not exist")
        return int(b)

    def add_revolute(self, body_i, point_i, body_j, point_j) -> int:
        """Pin body_i's local point_i [m] to body_j's local point_j (-1: ground, world point)."""
        bi = self._check_body(body_i, allow_ground=False)
        bj = self._check_body(body_j)
        geom = (point_i[0], point_i[1], point_j[0], point_j[1], 0.0, 0.0)
        self.joints.append((nb.JOINT_REVOLUTE, bi, bj, geom))
        return len(self.joints) - 1

    def add_prismatic(self, body, point, origin=(0.0, 0.0), angle=0.0, phi=0.0) -> int:
        """Let ``body`` slide along the ground axis through ``origin`` [m] at ``angle`` [rad],
        its rotation locked at ``phi`` [rad]; ``point`` [m] is the body point kept on the axis."""
        b = self._check_body(body, allow_ground=False)
        geom = (point[0], point[1], origin[0], origin[1], angle, phi)
        self.joints.append((nb.JOINT_PRISMATIC, b, -1, geom))
        return len(self.joints) - 1

    def add_prescribed_rotation(self, body, phi0, rate) -> int:
        """Rheonomic drive: phi(t) = phi0 [rad] + rate [rad/s] * t."""
        b = self._check_body(body, allow_ground=False)
        geom = (_finite("phi0", phi0), _finite("rate", rate), 0.0, 0.0, 0.0, 0.0)
        self.joints.append((nb.JOINT_ANGLE, b, -1, geom))
        return len(self.joints) - 1

    def add_spring(self, body_i, point_i, body_j, point_j, stiffness, damping, rest_length=None):
        """Linear spring-damper between two body points.

        Parameters
        ----------
        stiffness : float
            [N/m], >= 0.
        damping : float
            [N s/m], >= 0.
        rest_length : float, optional
            [m]; default: the initial distance.
        """
        bi = self._check_body(body_i)
        bj = self._check_body(body_j)
        k = _finite("stiffness", stiffness, nonneg=True)
        c = _finite("damping", damping, nonneg=True)
        if rest_length is None:
            q = np.array(self.q0, dtype=float).ravel()
            xi, yi, _, _ = nb.body_point(q, bi, float(point_i[0]), float(point_i[1]))
            xj, yj, _, _ = nb.body_point(q, bj, float(point_j[0]), float(point_j[1]))
            rest_length = float(np.hypot(xj - xi, yj - yi))
        rest = _finite("rest_length", rest_length, nonneg=True)
        self.springs.append((bi, bj, (point_i[0], point_i[1], point_j[0], point_j[1], k, c, rest)))
        return len(self.springs) - 1

    def add_contact(self, kind, body_a, point_a, radius_a, body_b, point_b, radius_b,
                    mu=0.0, e_N=0.0, e_T=0.0, name=None) -> int:
        """Unilateral frictional contact between a surface on body a and a sphere on body b.

        Parameters
        ----------
        kind : {"plane", "outside", "inside"}
            plane: ``radius_a`` is the plane's normal angle in body a's frame [rad] and
            ``point_a`` a point of the plane; outside: sphere b on sphere a; inside: sphere b
            inside the hollow sphere (ring) a of radius ``radius_a`` [m].
        body_a, body_b : int
            Body indices (-1: ground, for body a only).
        point_a, point_b : tuple
            Centres (or the plane point) in body coordinates [m].
        radius_b : float
            Sphere radius [m].
        mu, e_N, e_T : float
            Friction coefficient, normal and tangential restitution.
        """
        if kind not in CONTACT_KINDS:
            raise ValueError(f"contact kind {kind!r} is not allowed; allowed: "
                             + ", ".join(CONTACT_KINDS))
        a = self._check_body(body_a)
        b = self._check_body(body_b, allow_ground=False)
        ra = _finite("radius_a", radius_a) if kind == "plane" else _finite(
            "radius_a", radius_a, positive=True)
        rb = _finite("radius_b", radius_b, positive=True)
        mu = _finite("mu", mu, nonneg=True)
        for nm, e in (("e_N", e_N), ("e_T", e_T)):
            e = _finite(nm, e)
            if not 0.0 <= e <= 1.0:
                raise ValueError(f"{nm}: {e!r} is not allowed; allowed: in [0, 1]")
        if kind == "inside" and rb >= ra:
            raise ValueError(f"radius_b: {rb} must be smaller than the ring radius {ra}")
        geom = (point_a[0], point_a[1], point_b[0], point_b[1], ra, rb)
        self.contacts.append((CONTACT_KINDS[kind], a, b, geom, (mu, float(e_N), float(e_T))))
        self.contact_names.append(name or f"contact{len(self.contacts) - 1}")
        return len(self.contacts) - 1

    # -- arrays for the kernels --------------------------------------------------------------
    def arrays(self, damping_law: str = "flores", compliant: bool = False) -> nb.ModelArrays:
        """Flat arrays of the model, as the kernels take them (one namedtuple bundle).

        ``ct_hertz`` holds each contact's Hertz stiffness and damping factor for
        ``damping_law``; it is checked (e_N > 0 for Flores) only when ``compliant``."""
        nbody = len(self.body_names)
        if nbody == 0:
            raise ValueError("the model has no body")
        mass = np.array(self.mass, dtype=np.float64)
        inertia = np.array(self.inertia, dtype=np.float64)
        mdiag = np.empty(3 * nbody)
        mdiag[0::3] = mass
        mdiag[1::3] = mass
        mdiag[2::3] = inertia
        jt_type = np.array([j[0] for j in self.joints], dtype=np.int64)
        jt_body = np.array([[j[1], j[2]] for j in self.joints], dtype=np.int64).reshape(-1, 2)
        jt_geom = np.array([j[3] for j in self.joints], dtype=np.float64).reshape(-1, 6)
        sp_body = np.array([[s[0], s[1]] for s in self.springs], dtype=np.int64).reshape(-1, 2)
        sp_geom = np.array([s[2] for s in self.springs], dtype=np.float64).reshape(-1, 7)
        ct_type = np.array([c[0] for c in self.contacts], dtype=np.int64)
        ct_body = np.array([[c[1], c[2]] for c in self.contacts], dtype=np.int64).reshape(-1, 2)
        ct_geom = np.array([c[3] for c in self.contacts], dtype=np.float64).reshape(-1, 6)
        ct_law = np.array([c[4] for c in self.contacts], dtype=np.float64).reshape(-1, 3)
        if damping_law not in DAMPING_LAWS:
            raise ValueError(f"model.damping_law: {damping_law!r} is not allowed; allowed: "
                             + ", ".join(DAMPING_LAWS))
        kinds = {code: name for name, code in CONTACT_KINDS.items()}
        ct_hertz = np.zeros((len(self.contacts), 2))
        for k, (code, _a, _b, geom, law) in enumerate(self.contacts):
            ct_hertz[k, 0] = hertz_stiffness(kinds[code], geom[4], geom[5], self.youngs_modulus,
                                             self.poisson_ratio)
            if compliant or law[1] > 0.0 or damping_law != "flores":
                ct_hertz[k, 1] = damping_factor(law[1], damping_law)
        return nb.ModelArrays(mdiag=mdiag, mass=mass, gvec=np.array([0.0, -self.gravity]),
                              jt_type=jt_type, jt_body=jt_body, jt_geom=jt_geom,
                              sp_body=sp_body, sp_geom=sp_geom, ct_type=ct_type,
                              ct_body=ct_body, ct_geom=ct_geom, ct_law=ct_law,
                              ct_hertz=ct_hertz)

    def initial_state(self):
        """(q0, v0) as flat arrays."""
        return (np.array(self.q0, dtype=np.float64).ravel(),
                np.array(self.v0, dtype=np.float64).ravel())

    def constraint_rows(self) -> int:
        """Number of constraint rows of the joints: one for a prescribed rotation, two for a
        revolute or prismatic joint (counted here rather than by the kernel
        ``joint_row_count``, which would be one more compiled function to load in a new
        process)."""
        return sum(1 if kind == nb.JOINT_ANGLE else 2 for kind, *_ in self.joints)

    def drive_row(self) -> int:
        """Constraint row of the first prescribed rotation (the drive), or -1."""
        row = 0
        for kind, *_ in self.joints:
            if kind == nb.JOINT_ANGLE:
                return row
            row += 1 if kind == nb.JOINT_ANGLE else 2
        return -1

    # -- time loop ---------------------------------------------------------------------------
    def simulate(self, dt, t_end, rho_inf=0.0, tol=1e-5, max_iter=50, proximal=1e-6,
                 on_nonconvergence="error", progress=False, chunk=500,
                 contact_model="nonsmooth", damping_law="flores", friction_regularization=1e-4,
                 output_every=1, v_pre_min=1e-3, q0=None, v0=None, t0=0.0,
                 stop_when_released=False, energy_tol=0.005, watch_contacts=None,
                 watch_onset=None) -> Trajectory:
        """Integrate with the decoupled nonsmooth generalized-alpha scheme, or with compliant
        (Hertz) contacts in the generalized-alpha smooth step.

        Parameters
        ----------
        dt : float
            Time step h [s].
        t_end : float
            Duration [s] (from ``t0``); the number of steps is round(t_end / dt).
        rho_inf : float
            Spectral radius at infinity, in [0, 1].
        tol : float
            Newton tolerance (docs/method.md: m/s for velocities, |g|/h for gaps, relative for
            the smooth residual).
        max_iter : int
            Iteration cap per sub-problem.
        proximal : float
            Proximal regularisation eta of active contact rows [-] (nonsmooth).
        on_nonconvergence : {"error", "warn"}
            Raise :class:`SolverError` at the first unconverged step, or warn and flag it.
        progress : bool
            Print a progress bar on stderr.
        chunk : int
            Steps per kernel call (the progress bar and the error check run between calls).
        contact_model : {"nonsmooth", "compliant"}
            Impacts as impulses (the paper's scheme) or Hertz contact forces.
        damping_law : {"flores", "hunt_crossley", "lankarani_nikravesh"}
            Hysteresis damping of the compliant law.
        friction_regularization : float
            Slip speed below which the compliant Coulomb friction is linear [m/s], > 0.
        output_every : int
            Compliant: steps per output row (peaks and impulses are kept per interval).
            Nonsmooth: must be 1.
        v_pre_min : float
            Floor of the onset approach speed in the damping term [m/s].
        q0, v0 : array, optional
            Initial state (default: the bodies' initial values).
        t0 : float
            Start time [s] (matters for a prescribed rotation).
        stop_when_released : bool
            Compliant: stop at the end of the first chunk where every contact that closed
            during the run is open again (or, with ``watch_contacts``, where every watched
            group's contact episode has ended).
        watch_contacts : array of bool, optional
            Compliant, with ``stop_when_released``: groups of contacts to watch, shape (nc,)
            for one group or (groups, nc) (e.g. the contacts of one ball). A group's episode
            starts at the first output row where one of its onset contacts (``watch_onset``)
            carries a force and ends at the first later row where none of the group's contacts
            carries one; the run stops at the end of the first chunk after which every group's
            episode has ended. A group whose onset never comes runs the whole window. A force
            at row 0 alone (none at row 1) is no onset: a zoom starts from a nonsmooth run's
            state, where a contact about to be struck can sit within the solver's tolerance.
        watch_onset : array of bool, optional
            Onset contacts of each group, the shape of ``watch_contacts`` (default: the group's
            own contacts).
        energy_tol : float
            Energy audit (:mod:`simcore.model.audit`): a step creating more than this fraction
            of the
            run's energy scale counts as not converged.
        """
        dt = _finite("solver.dt", dt, positive=True)
        t_end = _finite("solver.t_end", t_end, positive=True)
        if t_end < dt:
            raise ValueError(f"solver.t_end: {t_end} is not allowed; allowed: >= solver.dt")
        if on_nonconvergence not in ("error", "warn"):
            raise ValueError(f"solver.on_nonconvergence: {on_nonconvergence!r} is not allowed; "
                             "allowed: 'error', 'warn'")
        if contact_model not in CONTACT_MODELS:
            raise ValueError(f"model.contact_model: {contact_model!r} is not allowed; allowed: "
                             + ", ".join(CONTACT_MODELS))
        compliant = contact_model == "compliant"
        v_reg = _finite("model.friction_regularization", friction_regularization, positive=True)
        output_every = int(output_every)
        if output_every < 1 or (not compliant and output_every != 1):
            raise ValueError(f"solver.output_dt: {output_every} steps per output is not "
                             "allowed; allowed: 1 for the nonsmooth model (its impulse filter "
                             "needs every step), a whole number >= 1 of steps for compliant")
        n_steps = int(round(t_end / dt))
        if n_steps % output_every:
            n_steps += output_every - n_steps % output_every
        arr = self.arrays(damping_law, compliant=compliant)
        q, v = self.initial_state()
        if q0 is not None:
            q = np.array(q0, dtype=np.float64).copy()
            v = np.array(v0, dtype=np.float64).copy()
        ndof = q.size
        nc = arr.ct_type.size
        nbil = self.constraint_rows()
        acc = np.zeros(ndof)
        vdot = np.zeros(ndof)
        lam_s = np.zeros(nbil)
        gap0 = np.zeros(nc)
        vn0 = np.zeros(nc)
        vt0 = np.zeros(nc)
        # the start uses the time loop's own kernels and work arrays (nothing else to compile)
        work = (nb.compliant_work(ndof, nbil, nc) if compliant
                else nb.nonsmooth_work(ndof, nbil, nc))
        sw = work.smooth
        nb.contact_velocities_into(q, v, arr, gap0, vn0, vt0, np.zeros(6), np.zeros(6), sw.trig)
        v_pre = np.maximum(-vn0, v_pre_min)
        f_contact = np.zeros(ndof)  # the compliant contact forces at the start
        if compliant:
            FN0, FT0 = np.zeros(nc), np.zeros(nc)
            nb.contact_forces(q, v, arr, v_pre, v_reg, f_contact, np.zeros((1, 1)),
                              np.zeros((1, 1)), False, FN0, FT0, gap0.copy(), vn0.copy(),
                              vt0.copy(), np.zeros((6, nc)))
        try:
            nb.initial_acceleration(q, v, float(t0), arr, f_contact, vdot, lam_s, sw)
        except np.linalg.LinAlgError as exc:
            raise SolverError(f"the joints at t = 0 are redundant or singular: {exc}") from None
        acc[:] = vdot
        lam_b = np.zeros(nbil)
        lamN = np.zeros(nc)
        lamT = np.zeros(nc)
        n_out = n_steps // output_every + 1
        watch = None
        if compliant and stop_when_released and watch_contacts is not None:
            watch = _ReleaseWatch(watch_contacts, watch_onset, nc)
        out = Trajectory(
            time=float(t0) + np.arange(n_out) * dt * output_every,
            q=np.zeros((n_out, ndof)), v=np.zeros((n_out, ndof)),
            lambda_N=np.zeros((n_out, nc)), lambda_T=np.zeros((n_out, nc)),
            nu_N=np.zeros((n_out, nc)), gap_N=np.zeros((n_out, nc)),
            vn_pre=np.zeros((n_out, nc)), vn_post=np.zeros((n_out, nc)),
            vn_free=np.zeros((n_out, nc)),
            energy=np.zeros(n_out), iterations=np.zeros((n_out, 3), np.int64),
            converged=np.ones(n_out, np.int8), drive_torque=np.zeros(n_out),
            contact_model=contact_model)
        out.q[0] = q
        out.v[0] = v
        out.gap_N[0] = gap0
        out.vn_pre[0] = vn0
        out.vn_post[0] = vn0
        out.vn_free[0] = vn0  # no jump at t = 0: the initial normal velocity
        drive_row = self.drive_row()
        if drive_row >= 0:
            out.drive_torque[0] = lam_s[drive_row]
        out.energy[0] = nb.total_energy(q, v, arr)
        settings = nb.StepSettings(float(dt), float(rho_inf), float(tol), int(max_iter),
                                   float(proximal), int(drive_row), float(t0), v_reg,
                                   float(v_pre_min))
        state = nb.StepState(q, v, acc, vdot, lam_s, lam_b, lamN, lamT, vn0, vt0)
        if compliant:
            out.F_N = np.zeros((n_out, nc))
            out.F_T = np.zeros((n_out, nc))
            out.F_N[0] = FN0
            out.F_T[0] = FT0
            out.energy[0] += nb.elastic_energy(q, arr)
            cstate = nb.CompliantState(
                v_pre=v_pre, closed=(gap0 < 0.0).astype(np.int8), FN=FN0, FT=FT0,
                gap=gap0.copy(), vn=vn0.copy(), vt=vt0.copy(), FN_max=np.zeros(nc),
                FT_at_max=np.zeros(nc), LN=np.zeros(nc), LT=np.zeros(nc),
                gap_min=np.full(nc, np.inf), vn_start=vn0.copy(),
                it_max=np.zeros(3, np.int64), ok=np.ones(1, np.int8))
            outputs = nb.CompliantOutputs(out.q, out.v, out.F_N, out.F_T, out.lambda_N,
                                          out.lambda_T, out.gap_N, out.vn_pre, out.vn_post,
                                          out.energy, out.iterations, out.converged,
                                          out.drive_torque)
            chunk = max(1, int(chunk) // output_every) * output_every

            def advance(k, k_next):
                return nb.integrate_compliant_chunk(k, k_next, output_every, settings, arr,
                                                    state, cstate, outputs, work)
        else:
            outputs = nb.ChunkOutputs(out.q, out.v, out.lambda_N, out.lambda_T, out.nu_N,
                                      out.gap_N, out.vn_pre, out.vn_post, out.vn_free,
                                      out.energy, out.iterations, out.converged,
                                      out.drive_torque)

            def advance(k, k_next):
                return nb.integrate_chunk(k, k_next, settings, arr, state, outputs, work)

        start = time.perf_counter()
        show = progress and sys.stderr.isatty()
        k = 0
        first_bad = -1
        ever_closed = np.zeros(nc, dtype=bool)
        audit = EnergyAudit(self, dt * output_every, n_out - 1, energy_tol, t0=t0)
        while k < n_steps:
            k_next = min(n_steps, k + chunk)
            k_prev = k
            try:
                bad = advance(k, k_next)
            except np.linalg.LinAlgError as exc:
                # a singular Newton matrix: report it as what it is, a failed step
                raise SolverError(f"singular Newton matrix between steps {k + 1} and {k_next} "
                                  f"(t = {t0 + (k + 1) * dt:.6g} to {t0 + k_next * dt:.6g} s): "
                                  f"{exc}") from None
            row0, row1 = k // output_every, k_next // output_every
            gain = audit.check(out.energy, out.drive_torque, out.converged, row0, row1)
            if gain >= 0 and first_bad < 0 and (bad < 0 or gain * output_every < bad):
                first_bad = gain * output_every
                if on_nonconvergence == "error":
                    raise SolverError(audit.message(gain))
                warnings.warn(audit.message(gain) + "; flagged in `converged`", RuntimeWarning,
                              stacklevel=2)
            if bad >= 0 and first_bad < 0:
                first_bad = int(bad)
                row = (bad + 1 + output_every - 1) // output_every
                stages = [s for s, it in zip(("smooth", "position", "velocity"),
                                             out.iterations[row], strict=True)
                          if it >= max_iter]
                msg = (f"solver did not converge at step {bad + 1} "
                       f"(t = {t0 + (bad + 1) * dt:.6g} s); stage(s) at the iteration cap: "
                       f"{', '.join(stages) or 'fallback'} (solver.max_iter = {max_iter}, "
                       f"solver.tol = {tol})")
                if on_nonconvergence == "error":
                    raise SolverError(msg)
                warnings.warn(msg + "; flagged in `converged`", RuntimeWarning, stacklevel=2)
            if not np.all(np.isfinite(q)):
                raise SolverError(f"non-finite state at step {k_next} "
                                  f"(t = {t0 + k_next * dt:.6g} s)")
            k = k_next
            if show:
                frac = k / n_steps
                bar = "#" * int(30 * frac)
                sys.stderr.write(f"\r[{bar:<30}] {100 * frac:5.1f}%  t = {t0 + k * dt:.4f} s")
                sys.stderr.flush()
            if watch is not None:
                if watch.released(out.F_N, k_prev // output_every, k // output_every + 1):
                    break
            elif compliant and stop_when_released:  # the rows written since the last check
                rows = slice(k_prev // output_every, k // output_every + 1)
                ever_closed |= (out.F_N[rows] > 0.0).any(axis=0)
                if ever_closed.any() and not (cstate.closed[ever_closed] > 0).any():
                    break
        if show:
            sys.stderr.write("\n")
        out.extras["step_state"] = state
        if compliant:
            out.extras["compliant_state"] = cstate
            out.vn_free[:] = out.vn_post
            if k < n_steps:  # stopped early: keep the rows written
                n_keep = k // output_every + 1
                for name in ("time", "q", "v", "lambda_N", "lambda_T", "nu_N", "gap_N",
                             "vn_pre", "vn_post", "vn_free", "energy", "iterations",
                             "converged", "drive_torque", "F_N", "F_T"):
                    setattr(out, name, getattr(out, name)[:n_keep])
                audit.error = audit.error[:n_keep]
                audit.tolerance = audit.tolerance[:n_keep]
        out.wall_time_s = time.perf_counter() - start
        out.first_unconverged_step = first_bad
        out.extras["energy_audit"] = audit
        return out
