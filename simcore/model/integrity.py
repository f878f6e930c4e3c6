"""Integrity checks of a run: cheap invariants of the bearing evaluated on every output row.

The time loop calls the checks a scene registered on its model
(:attr:`simcore.model.Model.checks`) after every chunk, on the rows the chunk wrote; a row that
breaks one counts as an unconverged step (``solver.on_nonconvergence``: ``error`` stops the
run, ``warn`` flags the row in ``converged`` and says which check failed, where and when). The
checks are invariants a correct run cannot break, not a second model: NumPy over the stored
positions and gaps, a few microseconds per row.

The crank-slider's bearing (:func:`bearing_checks`, docs/reliability.md, "Integrity checks"):

- **journal offset**: the distance of the outer ring's centre from the inner ring's stays
  below the rings' land gap (:attr:`simcore.model.bearing.BearingGeometry.land_gap`, where
  the lands of a real bearing meet and the model's ring guard closes) plus twice the largest
  Hertz deflection accepted (``solver.max_indentation`` x r_B, two contacts in series);
- **ball spacing**: no two ball centres closer than a ball diameter minus that deflection;
- **slider reach**: the slider within the crank-slider's reach, L2 - L1 - e <= x <= L1 + L2 + e
  with e the bound of the journal offset;
- **indentation** (compliant contacts): no contact indented deeper than
  ``solver.max_indentation`` x r_B, the range where Hertz's law holds (docs/model.md).

Each bound adds the position tolerance of the solver (``solver.tol`` x ``solver.dt``, the
accuracy of the position correction's joints and gaps).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Violation:
    """What a check found in a chunk of output rows.

    Attributes
    ----------
    check : str
        Name of the check (e.g. ``"journal offset"``).
    rows : numpy.ndarray
        Indices of every output row that breaks it (sorted).
    detail : str
        The first violation in words: the value found against the bound, with its reason.
    """

    check: str
    rows: np.ndarray
    detail: str


@dataclass(frozen=True)
class CheckSettings:
    """What a check needs of the run's settings.

    Attributes
    ----------
    max_indentation : float
        Largest accepted indentation of a contact over the ball radius [-]
        (``solver.max_indentation``).
    position_tolerance : float
        Accuracy of positions and gaps after a step [m] (``solver.tol`` x ``solver.dt``).
    compliant : bool
        The contacts are compliant (Hertz) forces.
    """

    max_indentation: float
    position_tolerance: float
    compliant: bool


def body_points(q, body: int, point) -> tuple[np.ndarray, np.ndarray]:
    """World coordinates (x, y) [m] of a point fixed in ``body`` (body coordinates ``point``
    [m]) for every row of ``q`` (rows, 3 n_bodies)."""
    x, y, phi = q[:, 3 * body], q[:, 3 * body + 1], q[:, 3 * body + 2]
    c, s = np.cos(phi), np.sin(phi)
    return x + c * point[0] - s * point[1], y + s * point[0] + c * point[1]


def _first(name: str, bad: np.ndarray, row0: int, detail) -> Violation | None:
    """A :class:`Violation` for the True rows of ``bad`` (rows ``row0`` ...), its detail made
    by ``detail(i)`` for the first one (index into ``bad``), or None."""
    idx = np.flatnonzero(bad)
    if idx.size == 0:
        return None
    return Violation(name, row0 + idx, detail(int(idx[0])))


@dataclass(frozen=True)
class BearingChecks:
    """The integrity checks of a crank-slider's bearing (module docstring).

    Parameters
    ----------
    crank, rod, slider : int
        Body indices.
    balls : tuple of int
        The balls' body indices.
    crank_pin, rod_big_end : tuple
        Inner- and outer-ring centres in the crank's and the rod's body frames [m].
    ball_radius : float
        r_B [m].
    land_gap : float
        Journal offset at which the rings' lands meet [m].
    crank_length, rod_length : float
        L1, L2 [m].
    """

    crank: int
    rod: int
    slider: int
    balls: tuple
    crank_pin: tuple
    rod_big_end: tuple
    ball_radius: float
    land_gap: float
    crank_length: float
    rod_length: float

    def deflection(self, settings: CheckSettings) -> float:
        """Largest accepted Hertz deflection of one contact [m]."""
        return settings.max_indentation * self.ball_radius

    def offset_bound(self, settings: CheckSettings) -> float:
        """Largest possible journal offset [m]: land gap + 2 deflections + tolerance."""
        return (self.land_gap + 2.0 * self.deflection(settings)
                + settings.position_tolerance)

    def journal_offset(self, traj, row0: int, row1: int, settings: CheckSettings):
        """The journal offset check on rows ``row0 .. row1 - 1`` of ``traj``."""
        q = traj.q[row0:row1]
        ax, ay = body_points(q, self.crank, self.crank_pin)
        cx, cy = body_points(q, self.rod, self.rod_big_end)
        offset = np.hypot(cx - ax, cy - ay)
        bound = self.offset_bound(settings)
        return _first("journal offset", ~(offset <= bound), row0, lambda i: (
            f"the outer ring's centre is {offset[i]:.4g} m from the inner ring's; allowed: "
            f"<= {bound:.4g} m (the rings' land gap {self.land_gap:.4g} m + 2 x "
            f"{self.deflection(settings):.3g} m of Hertz deflection, solver.max_indentation = "
            f"{settings.max_indentation:g} of the ball radius)"))

    def ball_spacing(self, traj, row0: int, row1: int, settings: CheckSettings):
        """The ball spacing check (every pair of balls) on rows ``row0 .. row1 - 1``."""
        q = traj.q[row0:row1]
        idx = 3 * np.asarray(self.balls)
        x, y = q[:, idx], q[:, idx + 1]
        n = idx.size
        # every pair, as the balls' distances to the ball s places further round the ring
        closest2 = np.full(q.shape[0], np.inf)
        for shift in range(1, n // 2 + 1):
            d2 = (x - np.roll(x, -shift, axis=1)) ** 2 + (y - np.roll(y, -shift, axis=1)) ** 2
            np.minimum(closest2, d2.min(axis=1), out=closest2)
        bound = (2.0 * self.ball_radius - self.deflection(settings)
                 - settings.position_tolerance)

        def detail(r):
            i, j = np.triu_indices(n, 1)
            dist = np.hypot(x[r, j] - x[r, i], y[r, j] - y[r, i])
            k = int(dist.argmin())
            return (f"the centres of balls {i[k]} and {j[k]} are {dist[k]:.4g} m apart; "
                    f"allowed: >= {bound:.4g} m (a ball diameter {2.0 * self.ball_radius:.4g} m "
                    f"minus {self.deflection(settings):.3g} m of Hertz deflection)")

        return _first("ball spacing", ~(np.sqrt(closest2) >= bound), row0, detail)

    def slider_reach(self, traj, row0: int, row1: int, settings: CheckSettings):
        """The slider reach check on rows ``row0 .. row1 - 1``."""
        x = traj.q[row0:row1, 3 * self.slider]
        play = self.offset_bound(settings)
        lo = self.rod_length - self.crank_length - play
        hi = self.rod_length + self.crank_length + play
        return _first("slider reach", ~((x >= lo) & (x <= hi)), row0, lambda r: (
            f"the slider is at x = {x[r]:.4g} m; allowed: in [{lo:.4g}, {hi:.4g}] m (rod "
            f"length -/+ crank length, -/+ the journal offset's bound {play:.3g} m)"))

    def indentation(self, traj, row0: int, row1: int, settings: CheckSettings):
        """The indentation check of compliant contacts on rows ``row0 .. row1 - 1`` (None
        for rigid contacts: the position correction keeps their gaps >= 0)."""
        if not settings.compliant:
            return None
        gap = traj.gap_N[row0:row1]
        limit = self.deflection(settings)
        deepest = -gap.min(axis=1) if gap.shape[1] else np.zeros(gap.shape[0])
        which = gap.argmin(axis=1) if gap.shape[1] else np.zeros(gap.shape[0], np.int64)
        return _first("indentation", ~(deepest <= limit), row0, lambda r: (
            f"contact {which[r]} is indented {deepest[r]:.4g} m "
            f"({deepest[r] / self.ball_radius:.3g} of the ball radius); allowed: <= "
            f"{limit:.4g} m, solver.max_indentation = {settings.max_indentation:g} of the ball "
            "radius (Hertz's range; raise model.youngs_modulus or solver.max_indentation)"))

    def all(self) -> list:
        """The four checks, as callables ``(traj, row0, row1, settings) -> Violation or
        None``."""
        return [self.journal_offset, self.ball_spacing, self.slider_reach, self.indentation]


def run_checks(checks, traj, row0: int, row1: int, settings: CheckSettings) -> list:
    """Every :class:`Violation` the ``checks`` find on rows ``row0 .. row1 - 1``, the one
    with the earliest row first."""
    found = [v for v in (check(traj, row0, row1, settings) for check in checks) if v]
    return sorted(found, key=lambda v: int(v.rows[0]))
