"""The Python driver of the time loop: solver settings in one object, a run in named stages.

:func:`simulate` integrates a :class:`~simcore.model.builder.Model` with the decoupled nonsmooth
generalized-alpha scheme, or with compliant (Hertz) contacts in the generalized-alpha smooth
step. The stages of a run:

1. :func:`_start` -- the model's arrays, the initial state and its acceleration;
2. :func:`_allocate` -- the output arrays (one row per output time, t0 included);
3. :class:`_Loop` -- the kernels integrate a chunk of steps at a time; between chunks the
   driver checks the chunk (convergence, the energy audit, a finite state, the model's
   integrity checks), shows progress and decides an early stop;
4. :func:`_finish` -- the rows of an early stop are trimmed and the run's records attached.

The kernels (:mod:`simcore.kernels`) take and return plain arrays; nothing here imports xarray.
"""

from __future__ import annotations

import sys
import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from .. import kernels as nb
from ..config import check_setting
from ..config.parameters import tidy
from ..kernels.bundles import STAGES
from ..kernels.compliant_adaptive import GROWTH_MAX
from .audit import ENERGY_FLOOR_J, EnergyAudit, drive_rate
from .integrity import CheckSettings, run_checks

CONTACT_MODELS = ("nonsmooth", "compliant")
#: defaults of the adaptive compliant step (docs/compliant.md, "Adaptive steps"): the smallest
#: step [s], the local error tolerance [m], the steps per Hertz contact time at a contact's
#: onset [-] and the largest growth the estimate may allow while a step keeps its size [-]
DT_MIN_DEFAULT = 1e-9
ADAPTIVE_TOL_DEFAULT = 1e-9
ONSET_STEPS_DEFAULT = 40.0
KEEP_GROWTH_DEFAULT = 1.5
#: allowed ``solver.adaptive_keep_growth``: from no band at all to the largest growth a step
#: may take
KEEP_GROWTH_RANGE = (1.0, GROWTH_MAX)
#: an adaptive run whose energy audit fails is run again with its tolerance over this
#: (``SolverSettings.adaptive_retries``; docs/compliant.md, "Energy and the tolerance")
RETRY_TOL_DIVISOR = 10.0
#: largest ``solver.adaptive_retries``
MAX_ADAPTIVE_RETRIES = 3
#: steps per kernel call by contact model when ``SolverSettings.chunk`` is None: a compliant
#: step costs about 5 us, the checks and the call between two chunks about 0.2 ms
#: (benchmarks/bench_compliant.py prints the paper case's time in 500-step chunks against this)
DEFAULT_CHUNK = {"nonsmooth": 500, "compliant": 5000}
#: largest ``solver.max_halvings``: a step taken as at most 2^10 substeps
MAX_HALVINGS = 10


class SolverError(RuntimeError):
    """A sub-problem of a step did not converge (with ``on_nonconvergence = "error"``)."""


class _TighterTolerance(Exception):
    """The energy audit failed in an adaptive run that may be run again with a smaller
    tolerance (``SolverSettings.adaptive_retries``)."""


def _finite(name, value, positive=False, nonneg=False):
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"{name}: {value!r} is not allowed; allowed: a finite number")
    if positive and value <= 0.0:
        raise ValueError(f"{name}: {value!r} is not allowed; allowed: > 0")
    if nonneg and value < 0.0:
        raise ValueError(f"{name}: {value!r} is not allowed; allowed: >= 0")
    return value


#: the configuration key of each :class:`SolverSettings` field a configuration sets: the
#: schema's range for that key is the field's (:func:`simcore.config.check_setting`), and
#: :meth:`SolverSettings.from_config` reads the field from it
SETTING_KEYS = {
    "dt": "solver.dt", "t_end": "solver.t_end", "rho_inf": "solver.rho_inf",
    "tol": "solver.tol", "max_iter": "solver.max_iter", "proximal": "solver.proximal",
    "on_nonconvergence": "solver.on_nonconvergence", "contact_model": "model.contact_model",
    "damping_law": "model.damping_law",
    "friction_regularization": "model.friction_regularization",
    "energy_tol": "solver.energy_tol", "max_halvings": "solver.max_halvings",
    "max_indentation": "solver.max_indentation", "adaptive": "solver.adaptive",
    "dt_min": "solver.dt_min", "adaptive_tol": "solver.adaptive_tol",
    "adaptive_keep_growth": "solver.adaptive_keep_growth",
    "adaptive_retries": "solver.adaptive_retries", "onset_speed": "solver.onset_speed",
}


@dataclass(frozen=True)
class SolverSettings:
    """Every setting of a run's time integration, checked when the object is made: a field a
    configuration sets (:data:`SETTING_KEYS`) against its key's range in the schema, as the
    configuration's value would be, and stored as the configuration holds it.

    Parameters
    ----------
    dt : float
        Time step h [s], > 0.
    t_end : float
        Duration [s] (from the start time), >= dt; the number of steps is round(t_end / dt),
        rounded up to whole output intervals.
    rho_inf : float
        Spectral radius at infinity, in [0, 1] [-].
    tol : float
        Newton tolerance (docs/method.md: m/s for velocities, |g|/h for gaps, relative for the
        smooth residual).
    max_iter : int
        Iteration cap per sub-problem, >= 1.
    proximal : float
        Proximal regularisation eta of active contact rows [-] (nonsmooth).
    on_nonconvergence : {"error", "warn"}
        Raise :class:`SolverError` at the first unconverged step, or warn and flag it.
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
        Floor of the onset approach speed in the compliant damping term [m/s].
    energy_tol : float
        Energy audit (:mod:`simcore.model.audit`): a step creating more than this fraction of
        the run's energy scale, alone or with the steps before it, counts as not converged [-].
    max_halvings : int
        Fixed steps: a step whose sub-problems do not converge, or (nonsmooth) that creates
        energy by the audit's criterion, is taken again from its start as 2, 4, ...
        2^max_halvings substeps (docs/method.md); only a step that fails at the smallest one is
        flagged or stops the run. 0: never retried; at most :data:`MAX_HALVINGS`. Adaptive
        compliant steps shrink a failed step instead.
    chunk : int or None
        Steps per kernel call (the checks, the progress bar and an early stop act between
        calls); with adaptive steps, chunk // output_every output intervals per call. None:
        :data:`DEFAULT_CHUNK` of the contact model.
    progress : bool
        Print a progress bar on stderr (when it is a terminal).
    max_indentation : float
        Largest indentation of a compliant contact over the ball radius, and the Hertz
        deflection the model's integrity checks allow (:mod:`simcore.model.integrity`) [-],
        in (0, 1].
    adaptive : bool
        Compliant: choose each step's size by the local error estimate (docs/compliant.md,
        "Adaptive steps"); ``dt`` is then the largest step and the output interval is
        ``output_every`` times ``dt``, as for a fixed step.
    dt_min : float
        Adaptive: the smallest step the error control may ask for [s], in (0, dt]; a step that
        needs less is taken at dt_min and counts as not converged.
    adaptive_tol : float
        Adaptive: the local error allowed in a step, as a length [m] (a body's translation, or
        its rotation times its radius of gyration), > 0.
    onset_steps : float
        Adaptive: a step in which a contact closes lasts at most the Hertz contact time of its
        approach speed over this many steps [-], > 0.
    adaptive_keep_growth : float
        Adaptive: a step keeps its planned size (and the Newton factors of that size keep
        serving) while the error estimate allows up to this factor of it [-], in [1, 2].
    adaptive_retries : int
        Adaptive: a run whose first failure is energy created by its steps (the energy audit)
        is run again from its start with ``adaptive_tol`` over :data:`RETRY_TOL_DIVISOR`, at
        most this many times; the audit's failure in the last try, and any other failure,
        stops the run or is flagged. 0: never; at most :data:`MAX_ADAPTIVE_RETRIES`.
    onset_speed : str
        Compliant, fixed steps: the onset speed of a contact that closes (the v_pre of its
        damping term), ``"crossing"`` (its approach speed where its gap crossed zero, from the
        step after the closing one on) or ``"last_open"`` (the approach speed of the last open
        state, a step before the crossing: first order in the step). Adaptive steps take the
        crossing's, in the closing step too.
    """

    dt: float
    t_end: float
    rho_inf: float = 0.0
    tol: float = 1e-5
    max_iter: int = 50
    proximal: float = 1e-6
    on_nonconvergence: str = "error"
    contact_model: str = "nonsmooth"
    damping_law: str = "flores"
    friction_regularization: float = 1e-4
    output_every: int = 1
    v_pre_min: float = 1e-3
    energy_tol: float = 0.005
    max_halvings: int = 4
    chunk: int | None = None
    progress: bool = False
    max_indentation: float = 0.1
    adaptive: bool = False
    dt_min: float = DT_MIN_DEFAULT
    adaptive_tol: float = ADAPTIVE_TOL_DEFAULT
    onset_steps: float = ONSET_STEPS_DEFAULT
    adaptive_keep_growth: float = KEEP_GROWTH_DEFAULT
    adaptive_retries: int = 1
    onset_speed: str = "crossing"

    def __post_init__(self):
        for name, key in SETTING_KEYS.items():  # each value as a configuration file's
            object.__setattr__(self, name, check_setting(key, getattr(self, name)))
        if self.t_end < self.dt:
            raise ValueError(f"solver.t_end: {self.t_end} is not allowed; allowed: >= "
                             "solver.dt")
        _finite("v_pre_min", self.v_pre_min, positive=True)
        every = int(self.output_every)
        if every < 1 or (not self.compliant and every != 1):
            raise ValueError(f"solver.output_dt: {every} steps per output is not allowed; "
                             "allowed: 1 for the nonsmooth model (its impulse filter needs every "
                             "step), a whole number >= 1 of steps for compliant")
        object.__setattr__(self, "output_every", every)
        if self.adaptive:
            self._check_adaptive()
        whole = isinstance(self.chunk, (int, np.integer)) and not isinstance(self.chunk, bool)
        if self.chunk is not None and not (whole and self.chunk >= 1):
            raise ValueError(f"chunk: {self.chunk!r} is not allowed; allowed: a whole number "
                             ">= 1 of steps, or None")

    def _check_adaptive(self) -> None:
        if not self.compliant:
            raise ValueError("solver.adaptive: true is not allowed with model.contact_model = "
                             "nonsmooth; allowed: false (adaptive steps are for compliant "
                             "contacts)")
        if self.dt_min > self.dt:
            raise ValueError(f"solver.dt_min: {self.dt_min!r} is not allowed; allowed: in "
                             f"(0, solver.dt = {self.dt!r}]")
        _finite("onset_steps", self.onset_steps, positive=True)

    @classmethod
    def from_config(cls, cfg, **changes) -> SolverSettings:
        """The settings of a validated configuration (its ``solver`` and ``model`` sections);
        ``changes`` replace single fields (e.g. ``t_end``)."""
        from ..config import output_every

        values = {"output_every": output_every(cfg)}
        for name, key in SETTING_KEYS.items():
            section, setting = key.split(".", 1)
            values[name] = cfg[section][setting]
        values.update(changes)
        return cls(**values)

    @property
    def compliant(self) -> bool:
        return self.contact_model == "compliant"

    @property
    def n_steps(self) -> int:
        """Steps of the run: round(t_end / dt), rounded up to whole output intervals."""
        n = int(round(self.t_end / self.dt))
        return n + (-n) % self.output_every

    @property
    def output_dt(self) -> float:
        """Time between output rows [s]."""
        return self.dt * self.output_every


@dataclass(frozen=True)
class ReleaseStop:
    """Stop a compliant run early once its contacts have let go.

    Without groups, the run stops at the end of the first chunk where every contact that closed
    during the run is open again. With ``watch_contacts``, groups of contacts are watched, shape
    (nc,) for one group or (groups, nc) (e.g. the contacts of one ball): a group's episode
    starts at the first output row where each of its onset contacts (``watch_onset``; default:
    any one of the group's contacts) carries a force (a pinch: both races of its ball) and ends
    at the first later row where none of the group's contacts carries one; the
    run stops at the end of the first chunk after which every group's episode has ended. A
    group whose onset never comes runs the whole window. A force at row 0 alone (none at row 1)
    is no onset: a zoom starts from a nonsmooth run's state, where a contact about to be struck
    can sit within the solver's tolerance.

    Parameters
    ----------
    watch_contacts : array of bool, optional
        Groups of contacts to watch.
    watch_onset : array of bool, optional
        Onset contacts of each group, the shape of ``watch_contacts``: the episode starts where
        all of them carry a force (default: where any of the group's own contacts does).
    """

    watch_contacts: object = None
    watch_onset: object = None


@dataclass
class Trajectory:
    """Plain-array result of :func:`simulate` (one row per output time, t0 included).

    Nonsmooth runs: one row per step, the impulses of the step's velocity jump; ``halvings``:
    the times the step was halved (0: taken whole; L: taken as 2^L substeps of dt / 2^L, its
    impulses summed; what the other rows hold then:
    :func:`simcore.kernels.nonsmooth_step.integrate_chunk`). Compliant runs:
    one row per output interval; ``lambda_N``/``lambda_T`` are the impulses over the interval,
    ``F_N`` the largest normal force in it and ``F_T`` the friction force at that peak,
    ``gap_N`` the smallest gap in it, ``vn_pre``/``vn_post`` the normal velocity at its start
    and end (``vn_free`` = ``vn_post``: nothing jumps), ``nu_N`` zero, ``halvings`` the most
    halvings of a fixed step in it (docs/method.md, "A failed step is taken again in halves")."""

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
    halvings: np.ndarray | None = None
    F_N: np.ndarray | None = None
    F_T: np.ndarray | None = None
    contact_model: str = "nonsmooth"
    wall_time_s: float = 0.0
    first_unconverged_step: int = -1
    extras: dict = field(default_factory=dict)

    #: the per-row arrays, trimmed together by an early stop
    ROW_FIELDS = ("time", "q", "v", "lambda_N", "lambda_T", "nu_N", "gap_N", "vn_pre",
                  "vn_post", "vn_free", "energy", "iterations", "converged", "drive_torque",
                  "halvings", "F_N", "F_T")

    #: the per-row arrays with one column per contact
    CONTACT_FIELDS = ("lambda_N", "lambda_T", "nu_N", "gap_N", "vn_pre", "vn_post", "vn_free",
                      "F_N", "F_T")

    def contact_columns(self, columns) -> Trajectory:
        """A copy whose per-contact arrays hold only ``columns`` (a slice or an index array of
        contacts, e.g. a bearing's ball-race contacts without its guard contacts); the other
        arrays and ``extras`` are shared."""
        parts = {name: getattr(self, name) for name in self.__dataclass_fields__}
        for name in self.CONTACT_FIELDS:
            if parts[name] is not None:
                parts[name] = parts[name][:, columns]
        return Trajectory(**parts)

    def keep_rows(self, n_keep: int) -> None:
        """Keep the first ``n_keep`` rows of every per-row array."""
        for name in self.ROW_FIELDS:
            value = getattr(self, name)
            if value is not None:
                setattr(self, name, value[:n_keep])


class _ReleaseWatch:
    """The group watch of :class:`ReleaseStop`: fed the force rows chunk by chunk; says when
    every group's episode ended."""

    def __init__(self, groups, onset, nc):
        groups = np.atleast_2d(np.asarray(groups, dtype=bool))
        self.onset_needs_all = onset is not None
        onset = groups if onset is None else np.atleast_2d(np.asarray(onset, dtype=bool))
        if groups.shape[1] > nc or onset.shape != groups.shape:
            raise ValueError(f"watch_contacts: shape {groups.shape} is not allowed; allowed: "
                             f"(nc,) or (groups, nc) booleans with nc = {nc} (or fewer: the "
                             "first contacts, e.g. a bearing's ball-race contacts without its "
                             "guard contacts), watch_onset the same shape")
        pad = ((0, 0), (0, nc - groups.shape[1]))  # contacts left out are not watched
        groups, onset = np.pad(groups, pad), np.pad(onset, pad)
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
                if not self.onset[g].any():  # an empty onset never comes
                    continue
                on = F[:, self.onset[g]]
                if row0 == 0 and on.shape[0] > 1:
                    on[0] &= on[1]  # a force at the first row alone is no onset
                first = np.flatnonzero(on.all(axis=1) if self.onset_needs_all
                                       else on.any(axis=1))
                if first.size == 0:
                    continue
                self.onset_row[g] = row0 + first[0]
            start = self.onset_row[g] - row0 + 1  # rows after the onset
            free = np.flatnonzero(~F[max(start, 0):, self.groups[g]].any(axis=1))
            if free.size:
                self.done[g] = True
        return bool(self.done.all())


class _AllReleased:
    """The plain :class:`ReleaseStop`: every contact that closed during the run is open."""

    def __init__(self, nc, closed):
        self.ever_closed = np.zeros(nc, dtype=bool)
        self.closed = closed  # the compliant state's per-contact flags, updated by the kernel

    def released(self, F_N, row0, row1) -> bool:
        self.ever_closed |= (F_N[row0:row1] > 0.0).any(axis=0)
        return bool(self.ever_closed.any() and not (self.closed[self.ever_closed] > 0).any())


@dataclass
class _Start:
    """What the time loop starts from: the model's arrays, the step state, the kernels' work
    arrays and the initial contact quantities."""

    arrays: object
    state: object
    work: object
    gap: np.ndarray
    vn: np.ndarray
    v_pre: np.ndarray
    F_N: np.ndarray | None
    F_T: np.ndarray | None
    drive_row: int


def _start(model, settings: SolverSettings, q0, v0, t0, v_pre0=None) -> _Start:
    """Stage 1: the model's arrays, the initial state and its generalized-alpha acceleration
    (the smooth equations at t0, compliant contact forces included). ``v_pre0``: the contacts'
    onset speeds [m/s] of a restart (default: each contact's approach speed now, floored at
    v_pre_min)."""
    compliant = settings.compliant
    arr = model.arrays(settings.damping_law, compliant=compliant)
    q, v = model.initial_state()
    if q0 is not None:
        q = np.array(q0, dtype=np.float64).copy()
        v = np.array(v0, dtype=np.float64).copy()
    ndof, nc, nbil = q.size, arr.ct_type.size, model.constraint_rows()
    # the start uses the time loop's own kernels and work arrays (nothing else to compile)
    work = (nb.compliant_work(ndof, nbil, nc) if compliant
            else nb.nonsmooth_work(ndof, nbil, nc))
    gap0, vn0, vt0 = np.zeros(nc), np.zeros(nc), np.zeros(nc)
    nb.contact_velocities_into(q, v, arr, gap0, vn0, vt0, np.zeros(6), np.zeros(6),
                               work.smooth.trig)
    v_pre = np.maximum(-vn0, settings.v_pre_min)
    if v_pre0 is not None:
        v_pre = np.array(v_pre0, dtype=np.float64).copy()
        if v_pre.shape != vn0.shape or not np.all(v_pre > 0.0):
            raise ValueError(f"v_pre0: {v_pre0!r} is not allowed; allowed: {nc} onset speeds "
                             "> 0 [m/s]")
    f_contact = np.zeros(ndof)  # the compliant contact forces at the start
    FN0 = FT0 = None
    if compliant:
        rec = nb.contact_records(nc)
        nb.contact_forces(q, v, arr, v_pre, settings.friction_regularization, f_contact,
                          np.zeros((1, 1)), np.zeros((1, 1)), False, rec)
        FN0, FT0 = rec[nb.FN_ROW].copy(), rec[nb.FT_ROW].copy()
    vdot, lam_s = np.zeros(ndof), np.zeros(nbil)
    try:
        nb.initial_acceleration(q, v, float(t0), arr, f_contact, vdot, lam_s, work.smooth)
    except np.linalg.LinAlgError as exc:
        raise SolverError(f"the joints at t = 0 are redundant or singular: {exc}") from None
    state = nb.StepState(q, v, vdot.copy(), vdot, lam_s, np.zeros(nbil), np.zeros(nc),
                         np.zeros(nc), vn0, vt0)
    return _Start(arr, state, work, gap0, vn0.copy(), v_pre, FN0, FT0, model.drive_row())


def _allocate(model, settings: SolverSettings, start: _Start, t0: float) -> Trajectory:
    """Stage 2: the output arrays, row 0 filled with the initial state."""
    n_out = settings.n_steps // settings.output_every + 1
    ndof, nc = start.state.q.size, start.gap.size
    rows = lambda *shape: np.zeros((n_out, *shape))  # noqa: E731
    out = Trajectory(
        time=float(t0) + np.arange(n_out) * settings.dt * settings.output_every,
        q=rows(ndof), v=rows(ndof), lambda_N=rows(nc), lambda_T=rows(nc), nu_N=rows(nc),
        gap_N=rows(nc), vn_pre=rows(nc), vn_post=rows(nc), vn_free=rows(nc),
        energy=np.zeros(n_out), iterations=np.zeros((n_out, 3), np.int64),
        converged=np.ones(n_out, np.int8), drive_torque=np.zeros(n_out),
        halvings=np.zeros(n_out, np.int8), contact_model=settings.contact_model)
    st = start.state
    out.q[0], out.v[0], out.gap_N[0] = st.q, st.v, start.gap
    # no jump at t = 0: the initial normal velocity before, after and free
    out.vn_pre[0] = out.vn_post[0] = out.vn_free[0] = start.vn
    if start.drive_row >= 0:
        out.drive_torque[0] = st.lam_s[start.drive_row]
    out.energy[0] = nb.total_energy(st.q, st.v, start.arrays)
    if settings.compliant:
        out.F_N, out.F_T = rows(nc), rows(nc)
        out.F_N[0], out.F_T[0] = start.F_N, start.F_T
        out.energy[0] += nb.elastic_energy(st.q, start.arrays)
    return out


def _chunk(settings: SolverSettings) -> int:
    """Steps per kernel call: ``settings.chunk``, else the contact model's default."""
    if settings.chunk is None:
        return DEFAULT_CHUNK[settings.contact_model]
    return int(settings.chunk)


def _kernel_settings(settings: SolverSettings, drive_row: int, t0: float):
    return nb.StepSettings(settings.dt, float(settings.rho_inf), float(settings.tol),
                           int(settings.max_iter), float(settings.proximal), int(drive_row),
                           float(t0), settings.friction_regularization,
                           float(settings.v_pre_min))


def _compliant_state(start: _Start):
    nc = start.gap.size
    return nb.CompliantState(
        v_pre=start.v_pre, closed=(start.gap < 0.0).astype(np.int8), FN=start.F_N,
        FT=start.F_T, gap=start.gap.copy(), vn=start.vn.copy(), vt=start.state.vt.copy(),
        FN_max=np.zeros(nc), FT_at_max=np.zeros(nc), LN=np.zeros(nc), LT=np.zeros(nc),
        gap_min=np.full(nc, np.inf), vn_start=start.vn.copy(),
        it_max=np.zeros(3, np.int64), ok=np.ones(1, np.int8), drive_impulse=np.zeros(1))


def _adaptive_state(model, settings: SolverSettings, start: _Start, n_out: int):
    """The adaptive loop's state (:class:`~simcore.kernels.AdaptiveState`): the first step
    planned at dt, and each coordinate's error weight, 1 for a position and the body's radius
    of gyration sqrt(I / m) [m] for its angle."""
    mdiag = start.arrays.mdiag
    weight = np.ones(mdiag.size)
    weight[2::3] = np.sqrt(mdiag[2::3] / mdiag[0::3])
    return nb.AdaptiveState(
        h=np.full(2, settings.dt), counts=np.zeros(5, np.int64), h_min=np.full(1, np.inf),
        t_flag=np.full(1, -1.0), weight=weight, row_steps=np.zeros(n_out, np.int64))


def _nonsmooth_outputs(out: Trajectory):
    """The output arrays :func:`~simcore.kernels.integrate_chunk` writes (views of ``out``)."""
    return nb.ChunkOutputs(out.q, out.v, out.lambda_N, out.lambda_T, out.nu_N, out.gap_N,
                           out.vn_pre, out.vn_post, out.vn_free, out.energy, out.iterations,
                           out.converged, out.drive_torque, out.halvings)


def _retry_settings(model, settings: SolverSettings):
    """When :func:`~simcore.kernels.integrate_chunk` takes a step again: at most
    ``settings.max_halvings`` times, where the step fails or creates energy by the energy
    audit's own criterion (:meth:`~simcore.model.audit.EnergyAudit.check`'s)."""
    return nb.RetrySettings(settings.max_halvings, float(settings.energy_tol), ENERGY_FLOOR_J,
                            drive_rate(model))


def _audit_first(gain: int, bad: int, every: int) -> bool:
    """Whether the energy audit's failure at ``gain`` (output row gain + 1) comes before the
    first unconverged step ``bad`` (0-based, -1: none) with ``every`` steps a row.

    The audit places a gain only to its row, so rows are compared: a step that failed in the
    audit's own row comes first (it may have made the energy), whatever ``every``."""
    return bad < 0 or gain + 1 < (bad + every) // every


class _Loop:
    """Stage 3: the chunks of the time loop and the checks between them."""

    def __init__(self, model, settings: SolverSettings, start: _Start, out: Trajectory,
                 t0: float, release: ReleaseStop | None, retries_done: int = 0):
        self.settings, self.out, self.t0 = settings, out, float(t0)
        self.retries_done = retries_done  # tries before this one, each at a larger tolerance
        self.state, self.work, self.arrays = start.state, start.work, start.arrays
        self.first_bad = -1
        self.adaptive = None
        kset = _kernel_settings(settings, start.drive_row, t0)
        every = settings.output_every
        if settings.compliant:
            self.cstate = _compliant_state(start)
            outputs = nb.CompliantOutputs(out.q, out.v, out.F_N, out.F_T, out.lambda_N,
                                          out.lambda_T, out.gap_N, out.vn_pre, out.vn_post,
                                          out.energy, out.iterations, out.converged,
                                          out.drive_torque, out.halvings)
            self.chunk = max(1, _chunk(settings) // every) * every
            if settings.adaptive:
                aset = nb.AdaptiveSettings(settings.output_dt, float(settings.dt_min),
                                           float(settings.adaptive_tol),
                                           float(settings.onset_steps),
                                           float(settings.adaptive_keep_growth))
                self.adaptive = _adaptive_state(model, settings, start, out.time.size)
                self._advance = lambda k, k_next: nb.integrate_compliant_adaptive(
                    k // every, k_next // every, kset, aset, start.arrays, start.state,
                    self.cstate, outputs, start.work, self.adaptive)
            else:
                at_crossing = settings.onset_speed == "crossing"
                self._advance = lambda k, k_next: nb.integrate_compliant_chunk(
                    k, k_next, every, settings.max_halvings, at_crossing, kset, start.arrays,
                    start.state, self.cstate, outputs, start.work)
        else:
            self.cstate = None
            outputs = _nonsmooth_outputs(out)
            retry = _retry_settings(model, settings)
            self.chunk = _chunk(settings)
            self._advance = lambda k, k_next: nb.integrate_chunk(
                k, k_next, kset, start.arrays, start.state, outputs, start.work, retry)
        self.release = self._release_watch(release, start.gap.size)
        self.audit = EnergyAudit(model, settings.output_dt, out.time.size - 1,
                                 settings.energy_tol, t0=t0)
        self.checks = list(model.checks)
        self.check_settings = CheckSettings(settings.max_indentation,
                                            settings.tol * settings.dt, settings.compliant)
        self.violations: dict[str, int] = {}  # output rows flagged by each integrity check

    def _release_watch(self, release, nc):
        if release is None or not self.settings.compliant:
            return None
        if release.watch_contacts is not None:
            return _ReleaseWatch(release.watch_contacts, release.watch_onset, nc)
        return _AllReleased(nc, self.cstate.closed)

    def _time(self, step: int) -> float:
        return self.t0 + step * self.settings.dt

    def run(self) -> int:
        """Integrate chunk by chunk; returns the number of steps done."""
        n_steps, every = self.settings.n_steps, self.settings.output_every
        show = self.settings.progress and sys.stderr.isatty()
        k = 0
        while k < n_steps:
            k_next = min(n_steps, k + self.chunk)
            bad = self._advance_chunk(k, k_next)
            self._check_chunk(bad, k // every, k_next // every)
            if not np.all(np.isfinite(self.state.q)):
                raise SolverError(f"non-finite state at step {k_next} "
                                  f"(t = {self._time(k_next):.6g} s)")
            self._check_integrity(k // every, k_next // every)
            k_prev, k = k, k_next
            if show:
                self._show_progress(k)
            if self.release is not None and self.release.released(
                    self.out.F_N, k_prev // every, k // every + 1):
                break
        if show:
            sys.stderr.write("\n")
        return k

    def _advance_chunk(self, k, k_next) -> int:
        """The kernels' steps ``k + 1 .. k_next``; the first unconverged step, or -1."""
        try:
            return self._advance(k, k_next)
        except np.linalg.LinAlgError as exc:
            # a singular Newton matrix: report it as what it is, a failed step
            raise SolverError(f"singular Newton matrix between steps {k + 1} and {k_next} "
                              f"(t = {self._time(k + 1):.6g} to {self._time(k_next):.6g} s): "
                              f"{exc}") from None

    def _check_chunk(self, bad: int, row0: int, row1: int) -> None:
        """The energy audit and the convergence of the chunk's steps: the first failure of
        the run stops it or is flagged (``on_nonconvergence``)."""
        out, every = self.out, self.settings.output_every
        terms = np.empty(row1 - row0)
        nb.energy_scale_terms_into(out.energy, out.q, self.arrays, row0, row1, terms)
        gain = self.audit.check(out.energy, out.drive_torque, out.converged, row0, row1, terms)
        if self.adaptive is not None and bad >= 0:  # (the kernel returns a row)
            bad = bad * every - 1  # (its last step)
        if gain >= 0 and self.first_bad < 0 and _audit_first(gain, bad, every):
            if self._retry_cures(gain, row0):
                raise _TighterTolerance(self.audit.message(gain))
            self.first_bad = gain * every
            self._fail(self.audit.message(gain) + self._step_hint())
        if bad >= 0 and self.first_bad < 0:
            self.first_bad = int(bad)
            self._fail(self._unconverged_message(bad))

    def _retry_cures(self, gain: int, row0: int) -> bool:
        """Whether the audit's failure at step ``gain`` (output row gain + 1) of a chunk from
        row ``row0`` is one a smaller tolerance cures: energy the steps created, finite, in
        an adaptive run with a retry left, before any row that breaks an integrity check (a
        blow-up, or a ball beyond Hertz's range, is not the steps' error)."""
        s = self.settings
        if not (s.adaptive and self.retries_done < s.adaptive_retries):
            return False
        if not np.isfinite(self.audit.error[gain + 1]):
            return False
        return not run_checks(self.checks, self.out, row0, gain + 2, self.check_settings)

    def _check_integrity(self, row0: int, row1: int) -> None:
        """The model's integrity checks on rows ``row0 .. row1``: every row that breaks one
        is flagged in ``converged``; the first failure of the run stops it or is warned about
        (``on_nonconvergence``), and so is the first failure of each further check."""
        every = self.settings.output_every
        for v in run_checks(self.checks, self.out, row0, row1 + 1, self.check_settings):
            self.out.converged[v.rows] = 0
            first_of_check = v.check not in self.violations
            self.violations[v.check] = self.violations.get(v.check, 0) + int(v.rows.size)
            step = int(v.rows[0]) * every
            if self.first_bad < 0 or step - 1 < self.first_bad:
                self.first_bad = step - 1  # (0-based, as the kernels count)
            elif not first_of_check:
                continue
            self._fail(f"integrity check '{v.check}' failed at step {step} "
                       f"(t = {self._time(step):.6g} s): {v.detail}" + self._step_hint())

    def _step_hint(self) -> str:
        """What to try after an integrity check or the energy audit failed in a run of fixed
        steps: a step too long for the motion breaks both (balls that bunch and pass the guard
        contacts, several contacts closing in one step, docs/reliability.md, section 4). An
        adaptive run's steps are the error control's, and its dt_min failure says so; it
        says whether it was run again at a smaller tolerance."""
        if self.adaptive is not None:
            if not self.retries_done:
                return ""
            return (f"; run again {self.retries_done} time(s) after the energy audit failed, "
                    f"solver.adaptive_tol now {self.settings.adaptive_tol:g} m "
                    f"(solver.adaptive_retries = {self.settings.adaptive_retries})")
        return (f"; a step too long for the motion is one cause: compare a smaller solver.dt "
                f"(now {self.settings.dt:g} s)")

    def _unconverged_message(self, bad: int) -> str:
        if self.adaptive is not None:
            return self._below_dt_min_message()
        every = self.settings.output_every
        row = (bad + 1 + every - 1) // every
        stages = [s for s, it in zip(STAGES, self.out.iterations[row], strict=True)
                  if it >= self.settings.max_iter]
        halvings = self.settings.max_halvings
        retried = (f"; taken again as up to {2 ** halvings} substeps (solver.max_halvings = "
                   f"{halvings})" if halvings else "")
        if halvings and not self.settings.compliant:  # (a compliant step has no jump)
            retried += (f", their velocity jump allowed "
                        f"{nb.RETRY_VELOCITY_ITERATIONS * self.settings.max_iter} iterations")
        return (f"solver did not converge at step {bad + 1} (t = {self._time(bad + 1):.6g} s); "
                f"stage(s) at the iteration cap: {', '.join(stages) or 'fallback'} "
                f"(solver.max_iter = {self.settings.max_iter}, solver.tol = {self.settings.tol})"
                + retried)

    def _below_dt_min_message(self) -> str:
        s = self.settings
        return (f"adaptive step: the step ending at t = {self.adaptive.t_flag[0]:.6g} s needed "
                f"less than solver.dt_min = {s.dt_min:g} s (its error estimate above "
                f"solver.adaptive_tol = {s.adaptive_tol:g} m, or its Newton iterations not "
                f"converged within solver.max_iter = {s.max_iter}, solver.tol = {s.tol}); "
                "taken at dt_min")

    def _fail(self, message: str) -> None:
        if self.settings.on_nonconvergence == "error":
            raise SolverError(message)
        # stacklevel 6: the caller of Model.simulate
        warnings.warn(message + "; flagged in `converged`", RuntimeWarning, stacklevel=6)

    def _show_progress(self, k: int) -> None:
        frac = k / self.settings.n_steps
        bar = "#" * int(30 * frac)
        sys.stderr.write(f"\r[{bar:<30}] {100 * frac:5.1f}%  t = {self._time(k):.4f} s")
        sys.stderr.flush()


def _finish(loop: _Loop, steps_done: int, wall_time_s: float) -> Trajectory:
    """Stage 4: trim the rows of an early stop, attach the run's records."""
    out, settings = loop.out, loop.settings
    out.extras["step_state"] = loop.state
    if settings.compliant:
        out.extras["compliant_state"] = loop.cstate
        out.vn_free[:] = out.vn_post
        if steps_done < settings.n_steps:  # stopped early: keep the rows written
            n_keep = steps_done // settings.output_every + 1
            out.keep_rows(n_keep)
            loop.audit.trim(n_keep)
    out.wall_time_s = wall_time_s
    out.first_unconverged_step = loop.first_bad
    out.extras["energy_audit"] = loop.audit
    out.extras["integrity"] = loop.violations
    if settings.compliant:  # (a record of the cost: Newton steps and chord iterates)
        out.extras["newton_steps"], out.extras["chord_iterates"] = (
            int(x) for x in loop.work.branches.stats)
    if loop.adaptive is not None:
        out.extras["adaptive"] = adaptive_records(loop.adaptive, steps_done
                                                  // settings.output_every + 1)
    return out


def adaptive_records(aw, n_rows: int) -> dict:
    """What an adaptive run records about its steps (run attributes): accepted and rejected
    steps (and why rejected), the smallest step taken [s], the steps taken below their need
    (at dt_min, flagged), and the steps of each output interval (``row_steps``, per row)."""
    c = aw.counts
    return {
        "n_steps_accepted": int(c[nb.ACCEPTED]),
        "n_steps_rejected": int(c[nb.REJECTED_ERROR] + c[nb.REJECTED_ONSET]
                                + c[nb.REJECTED_NEWTON]),
        "n_steps_rejected_error": int(c[nb.REJECTED_ERROR]),
        "n_steps_rejected_onset": int(c[nb.REJECTED_ONSET]),
        "n_steps_rejected_newton": int(c[nb.REJECTED_NEWTON]),
        "n_steps_below_dt_min": int(c[nb.BELOW_DT_MIN]),
        "dt_smallest_s": float(aw.h_min[0]) if np.isfinite(aw.h_min[0]) else float("nan"),
        "row_steps": aw.row_steps[:n_rows].copy(),
    }


def simulate(model, settings: SolverSettings, q0=None, v0=None, t0: float = 0.0,
             release: ReleaseStop | None = None, v_pre0=None) -> Trajectory:
    """Integrate ``model`` with ``settings``; see :meth:`simcore.model.Model.simulate`.

    An adaptive run whose energy audit fails is run again from its start with a tolerance
    :data:`RETRY_TOL_DIVISOR` times smaller, at most ``settings.adaptive_retries`` times: its
    energy error shrinks with the tolerance (docs/compliant.md, "Energy and the tolerance").
    The run records the tries (``n_tolerance_retries``), the tolerance of the last
    (``adaptive_tol_used``) and the steps all of them took (``n_steps_all_tries``, beside the
    last try's ``n_steps_accepted``); its wall time counts them all."""
    tol, retries, seconds, earlier_steps = settings.adaptive_tol, 0, 0.0, 0
    while True:
        start = _start(model, settings, q0, v0, t0, v_pre0)
        out = _allocate(model, settings, start, t0)
        loop = _Loop(model, settings, start, out, t0, release, retries)
        began = time.perf_counter()
        try:
            steps_done = loop.run()
        except _TighterTolerance as failed:
            retries += 1
            earlier_steps += int(loop.adaptive.counts[nb.ACCEPTED])
            # (tidy: 1e-11, not 1.0000000000000001e-11, in the records)
            settings = replace(settings, adaptive_tol=tidy(tol / RETRY_TOL_DIVISOR ** retries))
            if settings.progress and sys.stderr.isatty():
                sys.stderr.write(f"\n{failed}; run again at solver.adaptive_tol = "
                                 f"{settings.adaptive_tol:g} m\n")
            continue
        finally:
            seconds += time.perf_counter() - began
        out = _finish(loop, steps_done, seconds)
        if settings.adaptive:
            records = out.extras["adaptive"]
            records.update(n_tolerance_retries=retries, adaptive_tol_used=settings.adaptive_tol,
                           n_steps_all_tries=earlier_steps + records["n_steps_accepted"])
        return out
