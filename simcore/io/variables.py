"""The registry of a run file: every variable and coordinate it can hold, declared once.

Each entry gives the dimensions, the CF ``units`` and ``long_name`` written to the file, the type
the variable is stored as, and a description for readers of the code and the docs (in the manner
of xarray-simlab's variables). The dataset's stages (:mod:`simcore.io.dataset`) only compute
values and name them; dimensions and attributes come from here. A compliant run's variables that
mean something else in that model (impulses over an output interval, no velocity jump) carry a
second long name.

Stored types: float64 where digits matter (the impulses ``Lambda_N``, which the impulse filter
thresholds at ``analysis.zero_tol`` of the largest; the crank angle, which counts the
revolutions of long runs; the energy). float32 (about 7 significant digits) where the analysis
needs fewer or the figures only plot, and for the restart state of the compliant zoom
(``position``, ``angle``, ``velocity``, ``angular_velocity``): a zoom started from the float32
state gives the largest forces and contact times of the paper case's five largest impacts within
6e-5 (relative) of the zoom from the float64 run in memory, at E = 2.1e9 and 2.1e11 Pa
(``tests/test_io.py::test_zoom_from_the_default_file_agrees_with_the_zoom_from_memory``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..config.parameters import BASE_AXES, registry
from ..kernels.bundles import STAGES  # noqa: F401  (the labels of coordinate ``stage``)

#: CF version the files declare.
CONVENTIONS = "CF-1.10"

TIME_CONTACT = ("time", "contact")
TIME_GUARD = ("time", "guard")
TIME_BODY_AXIS = ("time", "body", "axis")
TIME_BODY = ("time", "body")
TIME = ("time",)

#: The longest ``long_name`` written (xarray labels a plot's axis with it): a longer text is
#: written as the CF ``comment``, under a shorter label (:attr:`RunVariable.label`).
LABEL_LENGTH = 80


def label_attrs(text: str, label: str | None = None) -> dict:
    """The ``long_name`` of a variable that means ``text``: the text itself where it is short
    enough for a label (:data:`LABEL_LENGTH`), else ``label``, with the whole text as the CF
    ``comment``.

    Raises
    ------
    ValueError
        A text longer than a label without a ``label`` of at most :data:`LABEL_LENGTH`
        characters (a registry's omission, caught by the tests of each file).
    """
    if len(text) <= LABEL_LENGTH:
        return {"long_name": text}
    if not label or len(label) > LABEL_LENGTH:
        raise ValueError(f"a long name of {len(text)} characters needs a label of at most "
                         f"{LABEL_LENGTH}: {text!r}")
    return {"long_name": label, "comment": text}


class RunVariable(NamedTuple):
    """One data variable of a run file."""

    dims: tuple[str, ...]
    units: str
    long_name: str
    #: NumPy type of the stored values (attribute ``storage`` of the variable says it too)
    storage: str
    #: what it is and who reads it (documentation only, not written to the file)
    description: str
    #: long name in a compliant run, where the value means something else there
    compliant_long_name: str | None = None
    #: further CF attributes, as (name, value) pairs
    extra: tuple = ()
    #: the long name written where the model's long name is longer than :data:`LABEL_LENGTH`
    #: (that text is then the ``comment``)
    label: str | None = None

    def attrs(self, compliant: bool = False, storage: str | None = None) -> dict:
        """The variable's attributes in a file: units, long name (a label, the longer text as
        ``comment``), ``extra``, storage."""
        text = self.compliant_long_name if compliant and self.compliant_long_name \
            else self.long_name
        out = {"units": self.units, **label_attrs(text, self.label)}
        out.update(self.extra)
        out["storage"] = storage or self.storage
        return out


#: Every data variable a run file can hold, in the order of the allowed names of
#: ``study.keep`` (the configuration schema lists them in this order).
VARIABLES: dict[str, RunVariable] = {
    "Lambda_N": RunVariable(
        TIME_CONTACT, "N s",
        "normal contact impulse of the velocity jump of the step ending at time", "float64",
        "What the impulse filter and the impact table read (analysis.split_impulses).",
        "normal contact impulse of the output interval ending at time, integral of F dt"),
    "Lambda_T": RunVariable(
        TIME_CONTACT, "N s", "tangential contact impulse along t = e_z x n", "float32",
        "Friction impulse, positive along t = e_z x n.",
        "tangential contact impulse over the output interval, along t = e_z x n"),
    "nu_N": RunVariable(
        TIME_CONTACT, "N s2", "position-correction multiplier of the contact", "float32",
        "Multiplier of the position correction; 0 in a compliant run.",
        "position-correction multiplier (0: compliant contacts have none)"),
    "gap_N": RunVariable(
        TIME_CONTACT, "m", "normal gap after the step (negative: penetration)", "float32",
        "Gap after the position correction (compliant: the smallest gap of the interval's "
        "steps at which it is evaluated: every step while the contact may close in it, and "
        "the interval's last; docs/compliant.md, 'What a step costs').",
        "smallest normal gap in the output interval (negative: indentation)"),
    "vn_pre": RunVariable(
        TIME_CONTACT, "m s-1",
        "normal relative velocity at the start of the step (negative: approaching)", "float32",
        "Normal velocity at the start of the step.",
        "normal relative velocity at the start of the output interval (< 0: approaching)"),
    "vn_post": RunVariable(
        TIME_CONTACT, "m s-1",
        "normal relative velocity after the velocity jump (negative: approaching)", "float32",
        "Normal velocity after the step.",
        "normal relative velocity at time (negative: approaching)"),
    "vn_free": RunVariable(
        TIME_CONTACT, "m s-1",
        "normal relative velocity before the velocity jump: smooth-step velocity at the "
        "corrected position (negative: approaching; t = 0: initial velocity)", "float32",
        "The approach speed an impact's peak force is computed from (docs/forces.md).",
        "normal relative velocity at time (compliant: no jump, = vn_post)",
        label="normal relative velocity before the velocity jump"),
    "position": RunVariable(
        TIME_BODY_AXIS, "m", "position of the body's centre of mass", "float32",
        "x, y of q; restart state of the compliant zoom (simcore.io.state_at)."),
    "angle": RunVariable(
        TIME_BODY, "rad", "rotation angle of the body, unwrapped", "float32",
        "phi of q; restart state of the compliant zoom."),
    "velocity": RunVariable(
        TIME_BODY_AXIS, "m s-1", "velocity of the body's centre of mass", "float32",
        "x, y of v; restart state of the compliant zoom."),
    "angular_velocity": RunVariable(
        TIME_BODY, "rad s-1", "angular velocity of the body", "float32",
        "phi of v; restart state of the compliant zoom."),
    "crank_angle": RunVariable(
        TIME, "rad", "crank angle, unwrapped", "float64",
        "Counts the revolutions of the summary's per-revolution figures."),
    "slider_x": RunVariable(
        TIME, "m", "slider position", "float32",
        "Plotted against the ideal slider-crank."),
    "slider_v": RunVariable(TIME, "m s-1", "slider velocity", "float32", "Slider velocity."),
    "journal_x": RunVariable(
        TIME, "m", "outer-race centre minus inner-race centre, x (journal orbit)", "float32",
        "The bearing's journal orbit (figures)."),
    "journal_y": RunVariable(
        TIME, "m", "outer-race centre minus inner-race centre, y (journal orbit)", "float32",
        "The bearing's journal orbit (figures)."),
    "energy": RunVariable(
        TIME, "J", "kinetic + gravitational + cage spring energy", "float64",
        "Mechanical energy; the energy audit compares its change with the drive's work.",
        "kinetic + gravitational + cage spring + contact elastic energy"),
    "drive_torque": RunVariable(
        TIME, "N m", "torque of the constant-speed drive (0 for the free drive)", "float32",
        "Torque of the prescribed crank angle."),
    "iterations": RunVariable(
        ("time", "stage"), "1", "Newton iterations of each sub-problem of the step (a "
        "velocity problem's Gauss-Seidel fallback adds its sweeps)", "int16",
        "Solver effort per stage (stored as int32 when a count exceeds int16).",
        "largest Newton iterations per step in the output interval (smooth: "
        "generalized-alpha step with contact forces, position: joint projection, "
        "velocity: 0)", label="Newton iterations of the step, per sub-problem"),
    "converged": RunVariable(
        TIME, "1", "1 where every sub-problem of the step converged, the step created no "
        "energy, alone or with the steps before it (energy audit), and broke no integrity "
        "check of the bearing", "int8",
        "0 marks a step the impact table flags as untrusted.",
        extra=(("flag_values", np.array([0, 1], dtype=np.int8)), ("flag_meanings", "no yes")),
        label="1 where the step converged, created no energy and broke no check"),
    "halvings": RunVariable(
        TIME, "1", "times the step was halved: 0 taken whole, L taken again as 2^L substeps of "
        "dt/2^L after a failure (impulses and drive torque: the step's sums and mean; "
        "iterations: the largest of its substeps)", "int8",
        "The retries of a failed step (docs/method.md); a compliant run with fixed steps: the "
        "most halvings of a step in the output interval.",
        "0: adaptive compliant steps are not halved (the error control shrinks them)",
        label="times the step was halved after a failure"),
    "steps": RunVariable(
        TIME, "1", "steps taken in the output interval ending at time (0 at the start)",
        "int32",
        "Adaptive compliant runs only (solver.adaptive): where the error control spent its "
        "steps; the sum over the rows is the attribute n_steps_accepted."),
    "energy_error": RunVariable(
        TIME, "J", "energy created by the step ending at time: energy change minus drive work "
        "(<= 0 when the step only dissipates)", "float32",
        "Written with the energy audit (simcore.model.audit).",
        label="energy created by the step ending at time"),
    "F_N": RunVariable(
        TIME_CONTACT, "N",
        "largest normal contact force in the output interval ending at time", "float32",
        "Compliant runs only."),
    "F_T": RunVariable(
        TIME_CONTACT, "N", "friction force along t = e_z x n at the instant of the largest "
        "normal force of the interval", "float32", "Compliant runs only.",
        label="friction force at the interval's largest normal force"),
    "guard_Lambda_N": RunVariable(
        TIME_GUARD, "N s",
        "normal impulse of a guard contact, velocity jump of the step ending at time",
        "float64",
        "The contacts that keep the bearing together (ball against ball, the rings' lands; "
        "docs/model.md, Guard contacts); with model.guard_contacts only.",
        "normal impulse of the guard contact over the output interval ending at time"),
    "guard_gap_N": RunVariable(
        TIME_GUARD, "m", "normal gap of the guard contact after the step", "float32",
        "Gap of a guard contact (the rings': the land gap less the journal offset).",
        "smallest normal gap of the guard contact in the output interval (< 0: overlap)"),
    "guard_F_N": RunVariable(
        TIME_GUARD, "N",
        "largest normal force of the guard contact in the output interval ending at time",
        "float32", "Compliant runs with guard contacts only."),
}

#: Stored type of every run variable.
STORAGE = {name: var.storage for name, var in VARIABLES.items()}

#: Every data variable a run file can hold (the allowed names of ``study.keep``).
RUN_VARIABLES = tuple(VARIABLES)

#: Default of ``study.keep``: what the impact analysis (``Lambda_N``, ``vn_free``,
#: ``converged``), the compliant zoom (the restart state), the summary (``iterations``,
#: ``crank_angle``), the figures (``slider_x``, ``journal_x``, ``journal_y``) and the README's
#: examples read; which steps were retried (``halvings``); ``F_N`` for compliant runs; the
#: guard contacts' load. (What a study reads back from its files, which a study's keep must
#: hold: ``analysis.reads``.)
DEFAULT_KEEP = ("Lambda_N", "vn_free", "position", "angle", "velocity", "angular_velocity",
                "crank_angle", "slider_x", "journal_x", "journal_y", "iterations", "converged",
                "halvings", "F_N", "guard_Lambda_N", "guard_F_N")


class RunCoordinate(NamedTuple):
    """One coordinate of a run file (labels have no units)."""

    dim: str
    units: str | None
    long_name: str

    def attrs(self) -> dict:
        out = {} if self.units is None else {"units": self.units}
        out["long_name"] = self.long_name
        return out


#: The coordinates of a run file but the swept parameters (:data:`PARAMETERS`), in file order.
COORDINATES: dict[str, RunCoordinate] = {
    "time": RunCoordinate("time", "s", "time since the start of the run"),
    "contact": RunCoordinate(
        "contact", "1",
        "ball-race contact index (balls 0..n-1 on the inner race, then on the outer race)"),
    "ball": RunCoordinate("contact", "1", "ball index of the contact"),
    "race": RunCoordinate("contact", None, "race of the contact (inner or outer)"),
    "body": RunCoordinate("body", None, "body name"),
    "axis": RunCoordinate("axis", None, "axis of the plane (x along the slider, y across)"),
    "stage": RunCoordinate("stage", None, "sub-problem of the nonsmooth generalized-alpha step"),
}

#: The coordinate of the guard contacts (names: ``ball0-ball1`` ..., ``rings``), in runs with them.
GUARD_COORDINATE = RunCoordinate(
    "guard", None, "guard contact: ball k against ball k+1, or the rings' lands")


#: The paper's four study parameters, ``{coordinate name: (units, long name)}`` (``clearance``,
#: ``mu``, ``omega0``, ``e_N``): scalar coordinates of every run file (a study adds its other
#: axes, :func:`study_coords`); taken from the registry of swept parameters
#: (:mod:`simcore.config.parameters`), which derives them from the schema.
PARAMETERS = {registry()[key].name: (registry()[key].units, registry()[key].long_name)
              for key in BASE_AXES}


def parameter_coords(values: dict, length_one: bool = True) -> dict:
    """Coordinates of swept parameters, with their units and long names (a category as its
    int8 code with ``flag_values``/``flag_meanings``), from the registry of swept parameters
    (:mod:`simcore.config.parameters`).

    Parameters
    ----------
    values : dict
        ``{"clearance": 4e-4, "model.cage_stiffness": 1e5, "solver_dt": 1e-4, ...}``: keys
        as a sweep writes them or coordinate names; keys that are not sweepable are ignored.
    length_one : bool
        True: each as the coordinate of a length-1 dimension of the same name (run files, so
        that ``open_mfdataset(..., combine="by_coords")`` works); False: scalar coordinates.

    Returns
    -------
    dict
        ``{name: (dims, values, attrs)}`` for ``xarray.Dataset(coords=...)``.
    """
    from ..config.parameters import canonical

    params = registry()
    out = {}
    for key, value in values.items():
        full = canonical(key, params)
        if full is None:
            continue
        param = params[full]
        data = param.stored(value)
        out[param.name] = (((param.name,), [data]) if length_one else ((), data)) + (
            param.attrs(),)
    return out


def base_parameters(model: dict) -> dict:
    """The values of :data:`PARAMETERS` in a ``model`` section."""
    return {name: model[name] for name in PARAMETERS}


def study_coords(ds, point: dict, axes, length_one: bool = True):
    """``ds`` with a study's coordinates: every value of ``point`` (``{sweep key: value}``,
    the grid point and ``model.contact_model``) as a coordinate (:func:`parameter_coords`),
    and the global attribute ``study_axes``, the coordinate names of the study's grid axes
    in order (space-separated), which the summary's dimensions follow."""
    from ..config.parameters import parameter

    ds = ds.assign_coords(parameter_coords(point, length_one=length_one))
    names = [parameter(key).name for key in axes]
    for name in PARAMETERS:
        if name in ds.dims and name not in names:
            # a run's parameter that is not an axis of the study (the clearance of a swept
            # clearance class) is a scalar coordinate, not a dimension: the runs then combine
            # into the study's grid, this coordinate along the axis that sets it
            ds = ds.squeeze(name)
    ds.attrs["study_axes"] = " ".join(names)
    return ds
