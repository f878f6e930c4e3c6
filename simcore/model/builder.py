"""A small planar multibody model builder.

The builder collects bodies, joints, spring-dampers and contacts, checks their inputs and hands
flat arrays (one :class:`simcore.kernels.ModelArrays` bundle) to the Numba kernels of
:mod:`simcore.kernels`; :meth:`Model.simulate` hands them to the time loop's driver
(:mod:`simcore.model.driver`). Scenes (the crank-slider bearing, the validation cases) are
builder functions on top of it, see :mod:`simcore.model.mechanism`.
"""

from __future__ import annotations

import numpy as np

from .. import kernels as nb
from . import driver
from .driver import (  # noqa: F401  (re-exported)
    CONTACT_MODELS,
    ReleaseStop,
    SolverError,
    SolverSettings,
    Trajectory,
    _finite,
)
from .hertz import DAMPING_LAWS, damping_factor, hertz_stiffness  # noqa: F401

CONTACT_KINDS = {"plane": nb.CONTACT_PLANE, "outside": nb.CONTACT_OUTSIDE,
                 "inside": nb.CONTACT_INSIDE}


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
        self.contact_grooves: list[float | None] = []  # groove radius across surface a [m]
        #: Integrity checks the time loop runs on every chunk of output rows, callables
        #: ``(trajectory, row0, row1, settings) -> Violation or None``
        #: (:mod:`simcore.model.integrity`); a scene registers its own.
        self.checks: list = []

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
                    mu=0.0, e_N=0.0, e_T=0.0, name=None, groove_radius=None) -> int:
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
        name : str, optional
            The contact's name (default ``contact<k>``).
        groove_radius : float, optional
            Radius of a groove in surface a across the plane of motion [m], larger than
            ``radius_b``: the sphere touches it on an ellipse, whose Hertz stiffness the
            compliant model takes (:func:`simcore.model.hertz.hertz_stiffness`). The contact's
            kinematics stay those of the plane. None: the circular contact of two spheres (a
            sphere and a plane).
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
        if groove_radius is not None:
            groove_radius = _finite("groove_radius", groove_radius, positive=True)
            if groove_radius <= rb:
                raise ValueError(f"groove_radius: {groove_radius} is not allowed; allowed: "
                                 f"larger than radius_b ({rb})")
        geom = (point_a[0], point_a[1], point_b[0], point_b[1], ra, rb)
        self.contacts.append((CONTACT_KINDS[kind], a, b, geom, (mu, float(e_N), float(e_T))))
        self.contact_grooves.append(groove_radius)
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
                                             self.poisson_ratio, self.contact_grooves[k])
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
    def simulate(self, settings: SolverSettings, q0=None, v0=None, t0: float = 0.0,
                 release: ReleaseStop | None = None, v_pre0=None) -> Trajectory:
        """Integrate with the decoupled nonsmooth generalized-alpha scheme, or with compliant
        (Hertz) contacts in the generalized-alpha smooth step (:mod:`simcore.model.driver`).

        Parameters
        ----------
        settings : SolverSettings
            Step, duration, tolerances, contact model, output sampling (checked when made).
        q0, v0 : array, optional
            Initial state (default: the bodies' initial values).
        t0 : float
            Start time [s] (matters for a prescribed rotation).
        release : ReleaseStop, optional
            Compliant: stop early once the contacts (or watched groups of contacts) have let
            go.
        v_pre0 : array, optional
            Compliant: the contacts' onset speeds at the start [m/s] (a restart from a
            compliant run's state, ``extras["compliant_state"].v_pre``); default: each
            contact's approach speed at the start, at least ``settings.v_pre_min``.

        Returns
        -------
        Trajectory
            Plain arrays, one row per output time.

        Raises
        ------
        SolverError
            At the first unconverged step, or one creating energy, with
            ``settings.on_nonconvergence = "error"``; at a singular Newton matrix or a
            non-finite state always.
        """
        return driver.simulate(self, settings, q0=q0, v0=v0, t0=t0, release=release,
                               v_pre0=v_pre0)
