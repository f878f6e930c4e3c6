"""Summary of a parameter study: one dataset over the swept parameters and the contact model.

Each grid point is run with the nonsmooth model (the paper's method: impulses, filter, Flores
forces) and, where the study asks for it, with the compliant model (Hertz contact forces, the
reference). One function, :func:`point_numbers`, reduces one run (with its impact table) to
its summary numbers; :func:`summarize` collects those numbers for every run and assembles the
grid. The numbers of a study run are computed once, by the simulate job from the run in memory,
and stored in its impact table (attributes ``summary_*``); :func:`summarize` reads them there,
and computes them from the files by the same function where a table lacks them (or carries them
for other settings).

Grid
----
The summary's dimensions are the swept parameters the runs carry as scalar coordinates (their
``units`` and ``long_name`` carried over), in the order of the first file, then ``model``
(0 nonsmooth, 1 compliant), ``race`` (0 inner, 1 outer), ``kind``, ``level``, ``rank``,
``stage``. Categories are small integer coordinates with ``flag_values``/``flag_meanings``.

Steady operation
----------------
The first ``settle`` crank revolutions of a run are its start-up: their forces give
``startup_peak_force`` and nothing else. Everything else (peak forces, p_max, counts) is taken
over the rest of the run, the *steady window*, and also per crank revolution of that window:
``peak_force`` is the largest force of the window per race, ``peak_force_rev_median`` the median
over its revolutions of each revolution's largest force (a statistic of every revolution, not
of the one that holds the maximum), ``peak_force_rev_spread`` how far apart those revolution
maxima lie, (largest - smallest) / median: near 0 where every revolution repeats the last.
(The spread is how the steady peak varies from one revolution to the next, not how much it
moves with the initial state: a peak that repeats within 8 % may move by 19 % when a ball
starts 1 nm elsewhere, and one that varies by 15 % from revolution to revolution may not move
at all; ``model.ball0_shift`` moves the start.) Revolutions are counted from the run's
``crank_angle`` (:class:`SteadyWindow`), so that they are right for the free drive too; a last
piece shorter than half a revolution joins the revolution before it.

Forces of the two models
------------------------
* nonsmooth: the impacts of the impact table (``F_max``, Flores; ``p_max``); counts of impacts,
  ``top3_force`` over stretches of load (:func:`analysis.impacts.loaded_stretches`).
* compliant: the contact force ``F_N`` itself (the largest of each output interval), ``p_max``
  from Hertz at that force; counts and ``top3_force`` over contact episodes
  (:mod:`analysis.episodes`).

``method_ratio`` (race) is the nonsmooth ``peak_force`` over the compliant one. The paper's
``peak_force`` is flagged (``peak_force_flagged`` = 1) where the impact that gives it carries a
flag (e.g. ``method_disagrees`` from its compliant zoom) or where the compliant twin differs by
more than ``analysis.method_tol``: |method_ratio - 1| > method_tol. ``static_deflection_ratio``
is the Hertz deflection of one ball (inner and outer contact in series) under the largest steady
load (the compliant twin's, else the nonsmooth one's), over the clearance: well below 1, a load
meets one ball (isolated impacts, the paper's method's case); near or above 1, several balls
share it.

Counts come in two kinds:

* ``n_impacts``/``impacts_per_rev`` (nonsmooth, by race and impact kind) count what the impulse
  filter calls an impact. Its zero threshold is relative (``zero_tol`` times the run's largest
  impulse), so it differs between runs; it is stored with the counts (``zero_threshold``).
* ``n_above``/``above_per_rev`` (by model, race and absolute force ``level``) count the impacts
  (nonsmooth) or contact episodes (compliant) whose force reaches ``level``; they compare across
  runs of one model.

A failed run (a marker file with attribute ``failed = 1``, written by the workflow when the
solver did not converge) gives ``failed = 1`` for its model and NaN in every other value of that
model at its point: missing, never zero.

The file is CF-1.10: every variable has UDUNITS ``units`` and a ``long_name`` (a label of at
most :data:`simcore.io.variables.LABEL_LENGTH` characters; a longer explanation is its
``comment``), and coordinates carry no fill value.
"""

from __future__ import annotations

import datetime
import itertools
import json
import threading
from contextlib import nullcontext
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Sequence

import numpy as np
import xarray as xr

from simcore.io.read import time_steps
from simcore.io.variables import STAGES, label_attrs
from simcore.model.driver import CONTACT_MODELS
from simcore.study.plan import SUMMARY_ONLY_SETTINGS

from .impacts import largest_first, loaded_stretches
from .reads import LIFE_READS, SUMMARY_READS, run_setting
from .run_life import conformities

__all__ = ["summarize", "summary_table", "steady_window", "SteadyWindow", "category_codes",
           "impact_numbers", "compliant_numbers", "point_numbers", "stored_numbers",
           "run_model", "MODELS", "STAGES", "RACES", "KINDS", "N_TOP", "STORED"]

#: Contact models of a grid point (code = position): 0 the paper's nonsmooth method, 1 the
#: compliant (Hertz) reference.
MODELS = CONTACT_MODELS
NONSMOOTH, COMPLIANT = 0, 1
#: Races of the bearing (code = position: 0 inner, 1 outer).
RACES = ("inner", "outer")
#: Impact kinds of the impact table (code = position).
KINDS = ("simple", "persistent", "pinch", "multi")
#: Number of largest peak forces kept per run.
N_TOP = 3
#: Prefix of the attributes in which a study impact table carries its run's summary numbers.
STORED = "summary_"
#: A last piece of the steady window shorter than this [revolutions] joins the one before it.
SHORT_TAIL = 0.5

_TWO_PI = 2.0 * np.pi
#: Coordinates of run files and impact tables that are not swept parameters.
_STRUCTURAL = {"time", "contact", "ball", "race", "body", "axis", "dof", "stage", "impact",
               "kind", "level", "rank", "model"}
#: The settings the numbers of a run depend on (stored with them, compared before reuse).
_NUMBER_SETTINGS = ("settle", "r_eff", "groove_conformity") + SUMMARY_ONLY_SETTINGS

# name: (dims besides the grid's, scope, units, long_name); scope: "model" (the variable has
# the model dimension), or the one model it comes from ("nonsmooth", "compliant")
_VARIABLES = {
    "peak_force": (
        ("race",), "model", "N",
        "largest contact force in the steady window, per race (nonsmooth: Flores peak force of "
        "an impact; compliant: F_N)"),
    "peak_force_rev_median": (
        ("race",), "model", "N",
        "median over the steady crank revolutions of each revolution's largest force, per race"),
    "peak_force_rev_spread": (
        ("race",), "model", "1",
        "spread of the steady crank revolutions' largest forces, (largest - smallest) / median, "
        "per race (missing with fewer than two revolutions or a median of 0 N)"),
    "p_max": (
        ("race",), "model", "Pa",
        "largest Hertz contact pressure in the steady window, per race (of the run's contacts: "
        "in-plane spheres, or its grooves, or analysis.groove_conformity's; a real groove "
        "spreads the load over an ellipse and gives less: p_max_groove)"),
    "p_max_groove": (
        ("race",), "model", "Pa",
        "Hertz contact pressure of a real deep-groove race at peak_force, per race: elliptical "
        "contact with the rating life's groove conformities (inner, outer); the "
        "pressure to hold against a bearing's limits (ISO 76: 4,200 MPa static; ISO 281's "
        "fatigue load limit: 1,500 MPa)"),
    "top3_force": (
        ("rank",), "model", "N",
        "largest forces of the steady window, decreasing, one per event (both races; an "
        "impact or a stretch of load on one contact, or a compliant contact episode); a pinch "
        "loads its ball on both races at once and gives a force on each"),
    "startup_peak_force": (
        (), "model", "N",
        "largest force of the start-up (the first analysis.settle crank revolutions), both races"),
    "n_above": (
        ("race", "level"), "model", "1",
        "impacts (nonsmooth) or contact episodes (compliant) in the steady window whose force "
        "reaches the level"),
    "above_per_rev": (
        ("race", "level"), "model", "1", "n_above per crank revolution of the steady window"),
    "ball_deflection_ratio": (
        (), "model", "1",
        "Hertz deflection of one ball (inner and outer contact in series) under the model's "
        "largest steady force, over the clearance"),
    "peak_force_flagged": (
        ("race",), "nonsmooth", "1",
        "1 where the paper's method's peak_force is not to be trusted: its impact carries a flag "
        "or the compliant twin differs by more than analysis.method_tol"),
    "n_impacts": (
        ("race", "kind"), "nonsmooth", "1",
        "impacts in the steady window (nonsmooth, relative zero threshold), by race and kind"),
    "impacts_per_rev": (
        ("race", "kind"), "nonsmooth", "1", "n_impacts per crank revolution of the steady window"),
    "n_flagged": (
        (), "nonsmooth", "1",
        "impacts in the steady window whose force carries a flag (missing where the impact table "
        "has no flags)"),
    "zero_threshold": (
        (), "nonsmooth", "N s",
        "zero threshold of the impulse filter (zero_tol times the run's largest impulse)"),
    "settle_time": (
        (), "model", "s",
        "end of the start-up: first time the crank has turned analysis.settle revolutions"),
    "revolutions": (
        (), "model", "1", "crank revolutions in the steady window, from the crank angle"),
    "max_Lambda_N": (
        (), "model", "N s",
        "largest normal impulse of the run (compliant: of an output interval)"),
    "iter_max": (("stage",), "model", "1", "largest number of Newton iterations per step"),
    "iter_mean": (("stage",), "model", "1", "mean number of Newton iterations per step"),
    "converged_fraction": (
        (), "model", "1", "fraction of the steps in which every sub-problem converged"),
    "wall_time_s": ((), "model", "s", "wall time of the simulation"),
    "time_steps": (
        (), "model", "1",
        "time steps of the run: of solver.dt (a nonsmooth or fixed-step compliant run), or the "
        "accepted adaptive steps (the study's compliant twins)"),
    "rings_on_lands_fraction": (
        (), "model", "1",
        "fraction of the output samples in which the rings ran on their lands (the balls had "
        "bunched; with a cage that should hold them, a step too large for the speed); missing "
        "for a run without guard contacts or a file that does not count them"),
    "failed": ((), "model", "1", "1 where the run failed (its other values are missing)"),
    "L10": (
        (), "compliant", "1e6",
        "ISO 281 basic rating life (C / P)^3 from the compliant twin's transmitted load over the "
        "steady window, in 10^6 revolutions"),
    "L10r": (
        (), "compliant", "1e6",
        "reference rating life from the compliant twin's ball loads (Lundberg-Palmgren raceway "
        "capacities, over-rollings counted per raceway element), in 10^6 revolutions"),
    "L10h": ((), "compliant", "h", "L10 in hours at the mean crank speed of the steady window"),
    "L10rh": ((), "compliant", "h", "L10r in hours at the mean crank speed of the steady window"),
    "equivalent_load": (
        (), "compliant", "N",
        "dynamic equivalent load P of L10: cubic mean of the transmitted radial load, weighted "
        "by revolutions"),
    "load_rating": (
        (), "compliant", "N",
        "basic dynamic load rating C of L10: analysis.life_load_rating where given, else the "
        "catalogue's (model.bearing), else Lundberg-Palmgren's from the model's balls and "
        "grooves (the paper's bearing)"),
    "static_load_rating": (
        (), "compliant", "N",
        "basic static load rating C0 (ISO 76): the catalogue's, else the radial load under "
        "which Stribeck's most loaded ball (5 C0 / Z) presses a groove with 4,200 MPa"),
    "static_equivalent_load": (
        (), "compliant", "N",
        "static equivalent load P0: the largest radial load the bearing transmits in the steady "
        "window (mean of an output interval)"),
    "static_safety_factor": (
        (), "compliant", "1",
        "static safety factor s0 = C0 / P0 (ISO 76; guideline values for rotating ball "
        "bearings 0.5-2 by the running quality asked, at least 1.5 under pronounced shock "
        "loads)"),
}
# computed over the grid from both models (not stored per run)
_GRID_VARIABLES = {
    "method_ratio": (("race",), "1", "the paper's method's steady peak force over the compliant "
                                     "model's (peak_force of model 0 over model 1)"),
    "static_deflection_ratio": ((), "1", "Hertz deflection of one ball (inner and outer contact "
                                         "in series) under the largest steady load, over the "
                                         "clearance (the compliant twin's load, else the "
                                         "nonsmooth one's)"),
}
#: ``long_name`` of the variables whose registry text above is longer than a label: that text
#: becomes their CF ``comment``.
_LABELS = {
    "peak_force": "largest contact force of the steady window, per race",
    "peak_force_rev_median": "median of the steady revolutions' largest forces, per race",
    "peak_force_rev_spread": "spread of the steady revolutions' largest forces, per race",
    "p_max": "largest Hertz contact pressure of the steady window, per race",
    "p_max_groove": "Hertz pressure of a real deep groove at peak_force, per race",
    "top3_force": "largest forces of the steady window, one per event",
    "startup_peak_force": "largest force of the start-up, both races",
    "n_above": "impacts or contact episodes of the steady window reaching the level",
    "ball_deflection_ratio": "Hertz deflection of a ball at the largest steady force / clearance",
    "peak_force_flagged": "1 where the paper's method's peak_force is not to be trusted",
    "n_impacts": "impacts in the steady window, by race and kind",
    "n_flagged": "impacts in the steady window whose force carries a flag",
    "time_steps": "time steps of the run",
    "rings_on_lands_fraction": "fraction of the output samples with the rings on their lands",
    "L10": "ISO 281 basic rating life L10",
    "L10r": "reference rating life L10r from the ball loads",
    "equivalent_load": "dynamic equivalent load P of L10",
    "load_rating": "basic dynamic load rating C of L10",
    "static_load_rating": "basic static load rating C0 (ISO 76)",
    "static_equivalent_load": "static equivalent load P0",
    "static_safety_factor": "static safety factor s0 = C0 / P0",
    "method_ratio": "the paper's method's steady peak force over the compliant model's",
    "static_deflection_ratio": "Hertz deflection of a ball at the largest steady load / clearance",
}
_COORDS = {
    "model": ("1", "contact model"),
    "rank": ("1", "rank of the force (1 = largest)"),
    "level": ("N", "absolute force level of the counts"),
    "race": ("1", "race of the contact"),
    "kind": ("1", "impact kind"),
    "stage": ("1", "sub-problem of the nonsmooth generalized-alpha step"),
}
_FLAGS = {"model": MODELS, "race": RACES, "kind": KINDS, "stage": STAGES}
_ORDER = ("model", "race", "kind", "level", "rank", "stage")


# --- the steady window ----------------------------------------------------------------------

def steady_window(time, crank_angle, settle: float) -> tuple[float, float]:
    """End of the start-up and the crank revolutions after it.

    Parameters
    ----------
    time : array_like
        Sample times [s], increasing.
    crank_angle : array_like
        Unwrapped crank angle at those times [rad].
    settle : float
        Start-up length [revolutions] (>= 0).

    Returns
    -------
    settle_time : float
        First sample time at which the crank has turned ``settle`` revolutions from its start
        [s]; the first sample time if ``settle`` is 0, the last one if the crank never turns
        that far (then the whole run is start-up).
    revolutions : float
        Net crank revolutions from ``settle_time`` to the end of the run [-] (0 if the crank
        never turned ``settle`` revolutions).
    """
    t = np.asarray(time, dtype=float)
    theta = np.asarray(crank_angle, dtype=float)
    if t.size == 0:
        return np.nan, np.nan
    turned = np.abs(theta - theta[0])
    target = _TWO_PI * float(settle)
    reached = np.flatnonzero(turned >= target * (1.0 - 1e-12))
    if reached.size == 0:
        return float(t[-1]), 0.0
    i = int(reached[0])
    return float(t[i]), float(abs(theta[-1] - theta[i]) / _TWO_PI)


@dataclass(frozen=True)
class SteadyWindow:
    """The steady window of a run and its crank revolutions.

    Attributes
    ----------
    settle_time : float
        End of the start-up [s] (-inf: the whole run is steady).
    revolutions : float
        Crank revolutions of the steady window [-] (NaN: unknown).
    time, turned : numpy.ndarray or None
        Sample times [s] and the revolutions turned since the end of the start-up at those
        times [-] (None without a crank angle: the revolutions are unknown).
    """

    settle_time: float
    revolutions: float
    time: np.ndarray | None = None
    turned: np.ndarray | None = None

    @classmethod
    def of_run(cls, run_ds: xr.Dataset, settle: float) -> SteadyWindow:
        """The window of a run (from its ``crank_angle``; without one the whole run is steady
        and its revolutions unknown)."""
        time = np.asarray(run_ds["time"].values, dtype=float)
        if "crank_angle" not in run_ds:
            return cls(float(time[0]) if time.size else -np.inf, np.nan)
        theta = np.asarray(run_ds["crank_angle"].values, dtype=float)
        settle_time, revolutions = steady_window(time, theta, settle)
        turned = np.abs(theta - theta[0]) / _TWO_PI - float(settle) if time.size else None
        return cls(settle_time, revolutions, time, turned)

    @property
    def n_revolutions(self) -> int:
        """Revolutions the per-revolution statistics run over (0: unknown or none)."""
        if self.turned is None or not self.turned.size or not self.turned[-1] > 0:
            return 0
        total = float(self.turned[-1])
        whole = int(np.floor(total + 1e-9))
        tail = total - whole
        return whole + (1 if (tail >= SHORT_TAIL or whole == 0) and tail > 1e-9 else 0)

    def revolution(self, t) -> np.ndarray:
        """Revolution index (0 .. n_revolutions - 1) of times ``t`` of the steady window."""
        n = self.n_revolutions
        position = np.interp(np.asarray(t, dtype=float), self.time, self.turned)
        return np.clip(np.floor(position + 1e-9), 0, max(n - 1, 0)).astype(np.int64)


def revolution_peak_table(window: SteadyWindow, time, race, force) -> np.ndarray:
    """Each steady revolution's largest force per race, (revolution, race) [N]: 0 for a
    revolution without a force on the race; no rows where the revolutions are unknown.

    Parameters
    ----------
    window : SteadyWindow
        The run's steady window.
    time, race, force : array_like
        Samples: time [s], race code (index into :data:`RACES`) and force [N]; samples of
        the start-up, non-finite or not positive forces and unknown races are left out.
    """
    time = np.asarray(time, dtype=float)
    race = np.asarray(race)
    force = np.asarray(force, dtype=float)
    per_rev = np.zeros((window.n_revolutions, len(RACES)))
    sel = ((time > window.settle_time) & np.isfinite(force) & (force > 0) & (race >= 0)
           & (race < len(RACES)))
    if per_rev.shape[0] and sel.any():
        np.maximum.at(per_rev, (window.revolution(time[sel]), race[sel]), force[sel])
    return per_rev


def _revolution_peaks(window: SteadyWindow, time, race,
                      force) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per race: the largest force of the steady window, the median over its revolutions of
    each revolution's largest force (:func:`revolution_peak_table`) and the spread of those,
    (largest - smallest) / median. NaN where the window has no force on the race; the median
    also where the revolutions are unknown, the spread also with fewer than two or a median
    of 0."""
    time = np.asarray(time, dtype=float)
    force = np.asarray(force, dtype=float)
    sel = (time > window.settle_time) & np.isfinite(force) & (force > 0)
    peak = np.full(len(RACES), np.nan)
    median = np.full(len(RACES), np.nan)
    spread = np.full(len(RACES), np.nan)
    per_rev = revolution_peak_table(window, time, race, force)
    n_rev = per_rev.shape[0]
    for r in range(len(RACES)):
        mine = sel & (race == r)
        if mine.any():
            peak[r] = float(np.max(force[mine]))
            if n_rev:
                median[r] = float(np.median(per_rev[:, r]))
            if n_rev > 1 and median[r] > 0:
                spread[r] = float(np.ptp(per_rev[:, r])) / median[r]
    return peak, median, spread


# --- numbers of one run -----------------------------------------------------------------------

def category_codes(values, meanings=None, names=RACES) -> np.ndarray:
    """Categories of an impact-table column as codes into ``names`` (-1: unknown or missing).

    Parameters
    ----------
    values : array_like
        Strings (older tables) or integer codes (newer ones; NaN where masked).
    meanings : str, optional
        The column's ``flag_meanings`` (space-separated names of codes 0, 1, ...); without it
        an integer code is taken to index ``names`` directly.
    names : sequence of str
        The categories of the summary.

    Returns
    -------
    numpy.ndarray of int
    """
    arr = np.asarray(values)
    lookup = {name: i for i, name in enumerate(names)}
    if arr.dtype.kind in "OUS":
        return np.array([lookup.get(v.decode() if isinstance(v, bytes) else str(v), -1)
                         for v in arr.ravel()], dtype=np.int64).reshape(arr.shape)
    codes = np.full(arr.shape, -1, dtype=np.int64)
    finite = np.isfinite(arr.astype(float))
    raw = np.where(finite, arr, -1).astype(np.int64)
    if meanings:
        table = np.array([lookup.get(name, -1) for name in str(meanings).split()], dtype=np.int64)
        ok = finite & (raw >= 0) & (raw < table.size)
        codes[ok] = table[raw[ok]]
    else:
        ok = finite & (raw >= 0) & (raw < len(names))
        codes[ok] = raw[ok]
    return codes


def _largest(values, mask) -> float:
    sel = values[mask & np.isfinite(values)]
    return float(sel.max()) if sel.size else np.nan


def _counts_above(force, race, steady, levels, revolutions) -> dict:
    """n_above (race, level) and above_per_rev of the steady rows."""
    reached = force[:, None] >= levels[None, :]  # NaN compares False
    n_above = np.array([np.sum(reached[steady & (race == r)], axis=0)
                        for r in range(len(RACES))], dtype=float).reshape(len(RACES), levels.size)
    per_rev = 1.0 / revolutions if np.isfinite(revolutions) and revolutions > 0 else np.nan
    return {"n_above": n_above, "above_per_rev": n_above * per_rev}


def _top(force, steady, events=None) -> np.ndarray:
    """The N_TOP largest finite ``force`` of the ``steady`` rows, decreasing, NaN-padded; with
    ``events`` (a number per row), only the largest of each event."""
    top = force[largest_first(force, np.flatnonzero(steady & np.isfinite(force)), events)]
    top = top[:N_TOP]
    out = np.full(N_TOP, np.nan)
    out[: top.size] = top
    return out


def impact_numbers(time, race, kind, f_max, p_max, flags, window: SteadyWindow,
                   levels: Sequence[float], events=None) -> dict:
    """Forces and counts of one nonsmooth impact table (plain arrays in, plain arrays out).

    Parameters
    ----------
    time : array_like
        Impact times [s]; an impact belongs to the steady window if
        ``time > window.settle_time``, to the start-up otherwise.
    race, kind : array_like of int
        Codes into :data:`RACES` and :data:`KINDS` (-1: unknown; such rows count in no race
        or kind, but in ``top3_force``, ``startup_peak_force`` and ``n_flagged``).
    f_max : array_like
        Flores peak forces [N] (NaN where there is none).
    p_max : array_like or None
        Peak contact pressures [Pa], None if the table has none.
    flags : array_like or None
        Flag bitmask of each force (0: clean), None if the table has none.
    window : SteadyWindow
        The run's steady window.
    levels : sequence of float
        Absolute force levels [N].
    events : array_like of int, optional
        An event number per row (:func:`analysis.impacts.loaded_stretches`: one for the rows
        of a persistent contact): ``top3_force`` ranks events, each with its largest force.
        None: it ranks rows. The counts always count rows.

    Returns
    -------
    dict of numpy.ndarray
        ``peak_force``, ``peak_force_rev_median``, ``peak_force_rev_spread``, ``p_max``,
        ``peak_force_flagged`` (race),
        ``top3_force`` (rank), ``startup_peak_force`` (), ``n_impacts`` and ``impacts_per_rev``
        (race, kind), ``n_above`` and ``above_per_rev`` (race, level), ``n_flagged`` ().
    """
    t = np.asarray(time, dtype=float).ravel()
    race = np.asarray(race, dtype=np.int64).ravel()
    kind = np.asarray(kind, dtype=np.int64).ravel()
    f = np.asarray(f_max, dtype=float).ravel()
    levels = np.asarray(levels, dtype=float)
    steady = t > window.settle_time
    n_race = len(RACES)
    peak, median, spread = _revolution_peaks(window, t, race, f)
    pressure = np.full(n_race, np.nan)
    if p_max is not None:
        p = np.asarray(p_max, dtype=float).ravel()
        pressure = np.array([_largest(p, steady & (race == r)) for r in range(n_race)])
    flagged = None if flags is None else np.asarray(flags, dtype=float).ravel()
    peak_flagged = np.full(n_race, np.nan)
    if flagged is not None:
        for r in range(n_race):
            idx = np.flatnonzero(steady & (race == r) & np.isfinite(f))
            if idx.size:
                peak_flagged[r] = float(flagged[idx[np.argmax(f[idx])]] != 0)
    n_impacts = np.array([[np.sum(steady & (race == r) & (kind == k)) for k in
                           range(len(KINDS))] for r in range(n_race)], dtype=float)
    revs = window.revolutions
    per_rev = 1.0 / revs if np.isfinite(revs) and revs > 0 else np.nan
    return {
        "peak_force": peak,
        "peak_force_rev_median": median,
        "peak_force_rev_spread": spread,
        "p_max": pressure,
        "peak_force_flagged": peak_flagged,
        "top3_force": _top(f, steady, None if events is None else np.ravel(events)),
        "startup_peak_force": np.array(_largest(f, ~steady)),
        "n_impacts": n_impacts,
        "impacts_per_rev": n_impacts * per_rev,
        **_counts_above(f, race, steady, levels, revs),
        "n_flagged": np.array(np.nan if flagged is None
                              else float(np.sum(steady & (flagged != 0)))),
    }


def race_forces(force: np.ndarray, races: np.ndarray) -> np.ndarray:
    """The largest force on each race per sample, (race, time) [N], from the contact forces
    ``force`` (contact, time) [N] and each contact's race code ``races`` (into :data:`RACES`);
    0 for a race without contacts."""
    return np.stack([force[races == r].max(axis=0) if np.any(races == r)
                     else np.zeros(force.shape[1]) for r in range(len(RACES))])


def compliant_numbers(run_ds: xr.Dataset, window: SteadyWindow, levels: Sequence[float],
                      stress) -> dict:
    """Forces and counts of one compliant run, from its contact forces ``F_N``.

    Parameters
    ----------
    run_ds : xarray.Dataset
        A compliant run (``F_N`` (time, contact), ``race`` on ``contact``).
    window : SteadyWindow
        The run's steady window.
    levels : sequence of float
        Absolute force levels [N].
    stress : callable or None
        (F [N], race code) -> (a, b, delta, p_max) (``run_geometry(...)["stress"]``); None:
        ``p_max`` missing.

    Returns
    -------
    dict of numpy.ndarray
        ``peak_force``, ``peak_force_rev_median``, ``peak_force_rev_spread``, ``p_max`` (race),
        ``top3_force`` (rank),
        ``startup_peak_force`` (), ``n_above``, ``above_per_rev`` (race, level): per sample the
        largest force of each race for the peaks, contact episodes
        (:func:`analysis.episodes.episode_peaks`) for ``top3_force`` and the counts.
    """
    from .episodes import compliant_forces, episode_peaks
    from .impacts import race_codes

    force = compliant_forces(run_ds)  # (contact, time)
    time = np.asarray(run_ds["time"].values, dtype=float)
    races = race_codes(run_ds, force.shape[0]).astype(np.int64)
    per_race = race_forces(force, races)
    sample_race = np.broadcast_to(np.arange(len(RACES))[:, None], per_race.shape)
    sample_time = np.broadcast_to(time[None, :], per_race.shape)
    peak, median, spread = _revolution_peaks(window, sample_time.ravel(), sample_race.ravel(),
                                             per_race.ravel())
    startup = time <= window.settle_time
    startup_peak = float(per_race[:, startup].max()) if startup.any() else np.nan
    contact, _, _, peak_index, episode_force = episode_peaks(force)
    steady = time[peak_index] > window.settle_time
    levels = np.asarray(levels, dtype=float)
    pressure = np.full(len(RACES), np.nan) if stress is None else _race_pressures(stress, peak)
    return {
        "peak_force": peak,
        "peak_force_rev_median": median,
        "peak_force_rev_spread": spread,
        "p_max": pressure,
        "top3_force": _top(episode_force, steady),
        "startup_peak_force": np.array(startup_peak if startup_peak > 0 else np.nan),
        **_counts_above(episode_force, races[contact], steady, levels, window.revolutions),
    }


def run_model(run_ds: xr.Dataset) -> int:
    """Contact model code of a run or failed-run marker (:data:`MODELS`)."""
    name = run_ds.attrs.get("model.contact_model", run_ds.attrs.get("contact_model",
                                                                    "nonsmooth"))
    if name not in MODELS:
        raise ValueError(f"run has contact_model {name!r}; allowed: {', '.join(MODELS)}")
    return MODELS.index(name)


def _run_numbers(run_ds: xr.Dataset, window: SteadyWindow) -> dict:
    """Solver statistics of a run (whole run; t = 0 is the initial state, not a step)."""
    steps = slice(1, None)
    n_stages = len(STAGES)
    iterations = (np.asarray(run_ds["iterations"].values[steps], dtype="f8")
                  if "iterations" in run_ds else np.zeros((0, n_stages)))
    converged = (np.asarray(run_ds["converged"].values[steps], dtype="f8")
                 if "converged" in run_ds else np.zeros(0))
    impulse = np.asarray(run_ds["Lambda_N"].values) if "Lambda_N" in run_ds else np.zeros(0)
    return {
        "settle_time": np.float64(window.settle_time),
        "revolutions": np.float64(window.revolutions),
        "max_Lambda_N": np.float64(np.max(impulse) if impulse.size else np.nan),
        "iter_max": np.max(iterations, axis=0) if iterations.size else np.full(n_stages, np.nan),
        "iter_mean": (np.mean(iterations, axis=0) if iterations.size
                      else np.full(n_stages, np.nan)),
        "converged_fraction": np.float64(np.mean(converged) if converged.size else np.nan),
        "wall_time_s": np.float64(run_ds.attrs.get("wall_time_s", np.nan)),
        "time_steps": np.float64(time_steps(run_ds)),
        "rings_on_lands_fraction": np.float64(
            run_ds.attrs["guard_rings_closed_samples"] / run_ds.sizes["time"]
            if "guard_rings_closed_samples" in run_ds.attrs else np.nan),
        "failed": np.float64(0.0),
    }


def _geometry(run_ds: xr.Dataset, settings: dict):
    """``run_geometry`` of the run for these settings, None where the run lacks the model's
    radii or material (hand-made files)."""
    from .impacts import run_geometry

    groove = settings.get("groove_conformity") or None
    try:
        return run_geometry(run_ds, settings.get("r_eff", "concave"), groove)
    except ValueError:
        return None


def _groove_pressure(run_ds: xr.Dataset, settings: dict, peak_force) -> np.ndarray:
    """Per race the pressure of an elliptical groove contact (the rating life's conformities,
    :func:`analysis.run_life.conformities`) at the race's ``peak_force`` [Pa]; NaN where the
    force is missing or the run lacks the model's radii or material."""
    from .impacts import run_geometry

    try:
        geo = run_geometry(run_ds, groove_conformity=conformities(run_ds, settings))
    except ValueError:
        return np.full(len(RACES), np.nan)
    return _race_pressures(geo["stress"], peak_force)


def _race_pressures(stress, force) -> np.ndarray:
    """Per race the Hertz pressure p_max [Pa] of ``stress`` ((F [N], race code) -> (a, b,
    delta, p_max), ``run_geometry(...)["stress"]``) at that race's ``force`` [N]; NaN where
    the force is missing or not positive."""
    pressure = np.full(len(RACES), np.nan)
    for r, f in enumerate(np.asarray(force, dtype=float)):
        if np.isfinite(f) and f > 0:
            pressure[r] = float(np.asarray(stress(np.array([f]), r)[3]).ravel()[0])
    return pressure


def _deflection_ratio(geo, peak_force, clearance) -> float:
    """Deflection of a ball's two contacts in series under the larger race peak, over the
    clearance (NaN without geometry, force or clearance)."""
    force = np.nanmax(peak_force) if np.isfinite(peak_force).any() else np.nan
    if geo is None or not np.isfinite(force) or not clearance > 0:
        return np.nan
    return float((force / geo["K_pinch"]) ** (2.0 / 3.0) / clearance)


def _impact_events(run_ds: xr.Dataset, impacts_ds: xr.Dataset | None):
    """The event number of each row of a run's impact table
    (:func:`analysis.impacts.loaded_stretches`), or None where the run or the table lacks
    what it reads (its impulses, the table's zero threshold)."""
    if impacts_ds is None or "Lambda_N" not in run_ds or "contact" not in impacts_ds \
            or "zero_threshold" not in impacts_ds.attrs:
        return None
    return loaded_stretches(run_ds, impacts_ds)


def _table_columns(impacts_ds: xr.Dataset | None) -> dict:
    """The columns the nonsmooth numbers read (None where the table lacks one)."""
    def column(name):
        if impacts_ds is not None and name in impacts_ds.variables \
                and impacts_ds[name].dims == ("impact",):
            return np.asarray(impacts_ds[name].values)
        return None

    def meanings(name):
        return impacts_ds[name].attrs.get("flag_meanings") \
            if impacts_ds is not None and name in impacts_ds.variables else None

    n = impacts_ds.sizes.get("impact", 0) if impacts_ds is not None else 0
    f_max = column("F_max")
    time, race, kind = column("time"), column("race"), column("kind")
    return {
        "time": np.full(n, np.inf) if time is None else time,  # no times: all steady
        "race": np.full(n, -1) if race is None else category_codes(race, meanings("race"), RACES),
        "kind": np.full(n, -1) if kind is None else category_codes(kind, meanings("kind"), KINDS),
        "f_max": np.full(n, np.nan) if f_max is None else f_max,
        "p_max": column("p_max"),
        "flags": column("flags"),
    }


def point_numbers(run_ds: xr.Dataset, impacts_ds: xr.Dataset | None, settings: dict) -> dict:
    """The summary numbers of one run (either model): the one reduction of the summary.

    A study's simulate job calls it with the run and its impact table still in memory and
    stores the result in the table's attributes (:func:`stored_attributes`); :func:`summarize`
    takes the numbers from there, or calls this function on the files where a table has none.

    Parameters
    ----------
    run_ds : xarray.Dataset
        The run (or the marker dataset of a failed run, attribute ``failed = 1``).
    impacts_ds : xarray.Dataset or None
        Its impact table (nonsmooth; :func:`analysis.study_tables.impact_table`); not read for
        a compliant run.
    settings : dict
        The ``analysis`` settings: ``settle`` [revolutions], ``force_levels`` [N], and where
        present ``r_eff`` and ``groove_conformity`` (for the compliant ``p_max`` and the ball
        deflection).

    Returns
    -------
    dict
        ``model`` (code) and the run's numbers (float64 arrays): the variables of the summary
        that have the ``model`` dimension, and for a nonsmooth run also ``peak_force_flagged``,
        ``n_impacts``, ``impacts_per_rev``, ``n_flagged``, ``zero_threshold``. A failed run
        gives ``failed`` = 1 only.
    """
    model = run_model(run_ds)
    if int(run_ds.attrs.get("failed", 0)):
        return {"model": model, "failed": np.float64(1.0)}
    levels = _levels(settings.get("force_levels", (100.0, 1000.0)))
    window = SteadyWindow.of_run(run_ds, float(settings.get("settle", 0.0)))
    geo = _geometry(run_ds, settings)
    numbers = {"model": model, **_run_numbers(run_ds, window)}
    if model == COMPLIANT:
        numbers.update(compliant_numbers(run_ds, window, levels,
                                         None if geo is None else geo["stress"]))
        numbers.update(_life_numbers(run_ds, window, settings))
    else:
        numbers.update(impact_numbers(**_table_columns(impacts_ds), window=window,
                                      levels=levels, events=_impact_events(run_ds, impacts_ds)))
        numbers["zero_threshold"] = np.float64(
            np.nan if impacts_ds is None else impacts_ds.attrs.get("zero_threshold", np.nan))
    numbers["p_max_groove"] = _groove_pressure(run_ds, settings, numbers["peak_force"])
    clearance = _clearance(run_ds)
    numbers["ball_deflection_ratio"] = np.float64(
        _deflection_ratio(geo, numbers["peak_force"], clearance))
    return {key: (value if key == "model" else np.asarray(value, dtype="f8"))
            for key, value in numbers.items()}


def _life_numbers(run_ds: xr.Dataset, window: SteadyWindow, settings: dict) -> dict:
    """The rating lives of a compliant run (:func:`analysis.run_life.compliant_life`); missing
    where the run file lacks what they read (variables, or the model's geometry: a hand-made
    file). Any other error is the analysis's and is raised."""
    from .run_life import GEOMETRY_SETTINGS, LIFE_NAMES, compliant_life

    if (any(name not in run_ds for name in LIFE_READS) or "body" not in run_ds.coords
            or any(run_setting(run_ds, key, None) is None for key in GEOMETRY_SETTINGS)):
        return dict.fromkeys(LIFE_NAMES, np.nan)
    return compliant_life(run_ds, window.settle_time, settings)


def _clearance(run_ds: xr.Dataset) -> float:
    return float(run_setting(run_ds, "clearance", np.nan))


# --- the numbers stored in a study's impact tables -----------------------------------------------

def _levels(force_levels) -> np.ndarray:
    return np.asarray(sorted(float(v) for v in force_levels), dtype=float)


@lru_cache(maxsize=1)
def _code_fingerprint() -> str:
    """A digest of the analysis package's sources: numbers stored by other code (a table made
    before an edit of the analysis) are computed again, not reused."""
    from simcore.study.plan import source_digest

    return source_digest(Path(__file__).resolve().parents[1], ("analysis",), ())


def _settings_key(settings: dict) -> str:
    """The settings the numbers depend on, and the code that computes them, as a canonical
    string."""
    canon = {"code": _code_fingerprint()}
    for key in _NUMBER_SETTINGS:
        value = settings.get(key)
        if key == "force_levels":
            value = [float(v) for v in _levels(value if value is not None else (100.0, 1000.0))]
        elif key == "settle":
            value = float(value or 0.0)
        elif key == "groove_conformity":
            value = float(value or 0.0)
        elif key == "r_eff":
            value = value or "concave"
        elif key == "life_conformity":
            value = None if value is None else [float(v) for v in value]
        elif key == "life_load_rating":
            value = None if value is None else float(value)
        canon[key] = value
    return json.dumps(canon, sort_keys=True)


def stored_attributes(numbers: dict, settings: dict) -> dict:
    """The numbers of :func:`point_numbers` as attributes of an impact table: ``summary_model``,
    ``summary_settings`` (the settings they were made with) and ``summary_<name>`` (float64,
    arrays flattened in C order)."""
    out = {f"{STORED}settings": _settings_key(settings)}
    for name, value in numbers.items():
        value = np.asarray(value, dtype="f8") if name != "model" else int(value)
        out[f"{STORED}{name}"] = value.ravel() if np.ndim(value) else (
            value if name == "model" else float(value))
    return out


def stored_numbers(attrs: dict, settings: dict) -> dict | None:
    """The numbers stored in a table's attributes for these settings, else None; None too where
    they lack one of the model's variables (a table written before the variable existed)."""
    if attrs.get(f"{STORED}settings") != _settings_key(settings):
        return None
    numbers = {}
    for key, value in attrs.items():
        if key.startswith(STORED) and key != f"{STORED}settings":
            name = key[len(STORED):]
            numbers[name] = int(value) if name == "model" else np.asarray(value, dtype="f8")
    if "model" not in numbers or "failed" not in numbers:
        return None
    if not float(numbers["failed"]):
        scopes = ("model", MODELS[numbers["model"]])
        if any(name not in numbers for name, (_, scope, _, _) in _VARIABLES.items()
               if scope in scopes):
            return None
    return numbers


# --- collecting every run ---------------------------------------------------------------------

#: netCDF4 is not safe for files opened from several threads at once (segmentation faults seen
#: with netCDF4 1.7.5); files are read one at a time, the numbers computed in parallel.
_READ_LOCK = threading.Lock()


#: Attributes of a swept parameter's coordinate carried into the summary.
_AXIS_ATTRS = ("units", "long_name", "flag_values", "flag_meanings", "sweep_key")


def _parameters(ds: xr.Dataset, axes=None) -> dict:
    """{name: (value, attrs)} of the swept parameters a file carries as scalar (or length-1)
    coordinates: ``axes`` where given, else every such numeric coordinate (a category is its
    int8 code)."""
    out = {}
    companions = _companions(axes) if axes is not None else {}
    for name, var in ds.coords.items():
        if (axes is not None and name not in axes and name not in companions) \
                or name in _STRUCTURAL \
                or np.asarray(var.values).dtype.kind not in "fiub":
            continue
        if var.ndim == 0 or (var.ndim == 1 and var.dims == (name,) and var.size == 1):
            attrs = {k: var.attrs[k] for k in _AXIS_ATTRS if k in var.attrs}
            out[name] = (float(np.asarray(var.values).item()), attrs)
    return out


def _companions(axes) -> dict[str, tuple]:
    """{coordinate: the axes that set it} for the study's parameters that other axes of it
    determine (the clearance of a swept clearance class, of a class for each swept bearing,
    :func:`simcore.study.plan.determiners`): a coordinate over those axes in the summary."""
    from simcore.config.parameters import canonical, registry
    from simcore.study.plan import determiners

    params = registry()
    keys = {canonical(name, params) for name in axes} - {None}
    return {params[key].name: tuple(params[k].name for k in by)
            for key, by in determiners(keys).items()}


def _entry(run_path, impact_path, settings: dict, axes=None, own=()) -> tuple[dict, dict]:
    """(parameters, numbers) of one run: stored in its table, else computed from the files;
    the ``analysis`` keys ``own`` from the run file's own attributes (:func:`summarize`)."""
    with _READ_LOCK:
        if own:
            with xr.open_dataset(run_path) as ds:
                settings = _own_settings(ds.attrs, settings, own)
        table = None
        if impact_path is not None:
            with xr.open_dataset(impact_path) as ds:
                numbers = stored_numbers(ds.attrs, settings)
                if numbers is not None:
                    return _checked(_parameters(ds, axes), axes, impact_path), numbers
                table = ds.load()
        with xr.open_dataset(run_path) as ds:
            model = run_model(ds)
            reads = SUMMARY_READS[MODELS[model]] + (LIFE_READS if model == COMPLIANT else ())
            run = ds.drop_vars([name for name in ds.data_vars if name not in reads]).load()
    parameters = _checked(_parameters(run, axes), axes, run_path)
    if table is not None and table.sizes.get("impact", 0) and run_model(run) == NONSMOOTH:
        missing = sorted(set(parameters) - set(_parameters(table, axes)))
        if missing:
            raise ValueError(f"{impact_path}: scalar coordinate {missing[0]} is missing")
    return parameters, point_numbers(run, table, settings)


def _own_settings(attrs, settings: dict, own) -> dict:
    """``settings`` with the keys ``own`` taken from a run file's ``analysis.<key>``
    attributes where it has them (a null setting is not stored: the study's value stands)."""
    out = dict(settings)
    for key in own:
        value = attrs.get(f"analysis.{key}")
        if value is not None:
            out[key] = value.item() if isinstance(value, np.generic) else value
    return out


def _checked(parameters: dict, axes, path) -> dict:
    wanted = list(axes) if axes is not None else []
    missing = [name for name in wanted if name not in parameters]
    if missing or not parameters:
        what = missing[0] if missing else "(none: no swept parameter)"
        raise ValueError(f"{path}: scalar coordinate {what} is missing")
    return parameters


#: The schedulers :func:`summarize` takes by name (else an address ``host:port``, which the
#: schema's ``study.dask_scheduler`` checks before any job); None and "" are "threads".
NAMED_SCHEDULERS = ("threads", "synchronous", "local")


def _scheduler(scheduler, num_workers):
    """Context and compute() keywords for local threads, a new local cluster or an address."""
    if scheduler in (None, "", "threads"):
        return nullcontext(), {"scheduler": "threads", "num_workers": num_workers}
    if scheduler == "synchronous":
        return nullcontext(), {"scheduler": "synchronous"}
    from distributed import Client, LocalCluster

    if scheduler == "local":
        cluster = LocalCluster(n_workers=num_workers or 1, threads_per_worker=1,
                               processes=True, dashboard_address=None)
        return Client(cluster), {}
    return Client(scheduler), {}


def _collect(pairs, settings, axes, scheduler, num_workers, own=()) -> list:
    """:func:`_entry` of every (run, table) pair, on the chosen dask scheduler."""
    import dask

    context, compute_kw = _scheduler(scheduler, num_workers)
    tasks = [dask.delayed(_entry, pure=True)(str(run), None if table is None else str(table),
                                             settings, axes, own) for run, table in pairs]
    with context:
        return list(dask.compute(*tasks, **compute_kw))


# --- the grid ---------------------------------------------------------------------------------

def _shape(dims, n_levels) -> tuple:
    sizes = {"race": len(RACES), "kind": len(KINDS), "level": n_levels, "rank": N_TOP,
             "stage": len(STAGES)}
    return tuple(sizes[d] for d in dims)


def _registry_attrs(name: str) -> dict:
    """The coordinate attributes of a swept parameter from the registry of swept parameters
    ({} for a name it does not know)."""
    try:
        from simcore.config.parameters import parameter

        return {k: v for k, v in parameter(name).attrs().items() if k in _AXIS_ATTRS}
    except (ImportError, KeyError, ValueError):
        pass
    try:
        from simcore.io import PARAMETERS
    except ImportError:
        return {}
    if name not in PARAMETERS:
        return {}
    units, long_name = PARAMETERS[name]
    return {"units": units, "long_name": long_name}


def _axis_attrs(name: str, from_files: dict | None) -> dict:
    """A swept parameter's coordinate attributes in the summary. Units and long name come from
    the registry where it knows the parameter, so that a study whose run files were written
    before a change of them (files are reused while their run's fingerprint holds) reads the
    current ones; the meanings of a category's codes (``flag_values``, ``flag_meanings``) come
    from the files that hold the codes. Neither: units 1 and the name."""
    known = _registry_attrs(name)
    if not from_files:
        return known or {"units": "1", "long_name": name}
    return {**from_files, **{k: known[k] for k in ("units", "long_name") if k in known}}


def _assemble(entries: list, levels: np.ndarray, models: list[int], axes=None) -> xr.Dataset:
    """The grid of every run's numbers (missing points and models NaN)."""
    names = list(axes) if axes is not None else list(
        dict.fromkeys(name for parameters, _ in entries for name in parameters))
    attrs = {}
    for parameters, _ in entries:
        for name, (_, a) in parameters.items():
            attrs.setdefault(name, a)
    axis_values = {name: np.array(sorted({p[name][0] for p, _ in entries if name in p}),
                                  dtype=float) for name in names}
    grid = tuple(axis_values[name].size for name in names)
    arrays = {name: np.full(grid + ((len(models),) if scope == "model" else ())
                            + _shape(dims, levels.size), np.nan)
              for name, (dims, scope, _, _) in _VARIABLES.items()}
    for parameters, numbers in entries:
        missing = [name for name in names if name not in parameters]
        if missing:
            raise ValueError(f"a run lacks the swept parameter {missing[0]} that others carry")
        at = tuple(int(np.searchsorted(axis_values[name], parameters[name][0]))
                   for name in names)
        m = models.index(int(numbers["model"]))
        for name, (dims, scope, _, _) in _VARIABLES.items():
            if name not in numbers or scope not in ("model", MODELS[int(numbers["model"])]):
                continue
            index = at + ((m,) if scope == "model" else ())
            arrays[name][index] = np.asarray(numbers[name]).reshape(_shape(dims, levels.size))
    coords = {}
    for name in names:
        values = axis_values[name]
        if "flag_values" in attrs.get(name, {}):  # a category: its int8 code
            values = values.astype(np.int8)
        coords[name] = (name, values, _axis_attrs(name, attrs.get(name)))
    for name, by in _companions(names).items():  # e.g. the clearance of each class
        value_at = {tuple(p[d][0] for d in by): p[name][0] for p, _ in entries
                    if name in p and all(d in p for d in by)}
        values = np.array([value_at.get(at, np.nan) for at in
                           itertools.product(*(axis_values[d] for d in by))])
        coords[name] = (by, values.reshape([axis_values[d].size for d in by]),
                        _axis_attrs(name, attrs.get(name)))
    coords.update(model=np.array(models, dtype=np.int8),
                  race=np.arange(len(RACES), dtype=np.int8),
                  kind=np.arange(len(KINDS), dtype=np.int8), level=levels,
                  rank=np.arange(1, N_TOP + 1), stage=np.arange(len(STAGES), dtype=np.int8))
    data = {name: (names + (["model"] if scope == "model" else []) + list(dims), arrays[name])
            for name, (dims, scope, _, _) in _VARIABLES.items()}
    return xr.Dataset(data, coords=coords)


def _across_models(summary: xr.Dataset, method_tol) -> xr.Dataset:
    """method_ratio, static_deflection_ratio and the method check of peak_force_flagged
    (``method_tol``: a number, or a DataArray over the grid's axes)."""
    model = list(summary["model"].values)

    def of(name, code):
        if code in model:
            return summary[name].sel(model=code, drop=True)
        return xr.full_like(summary[name].isel(model=0, drop=True), np.nan)

    paper, reference = of("peak_force", NONSMOOTH), of("peak_force", COMPLIANT)
    ratio = paper / reference.where(reference > 0)
    deflection = of("ball_deflection_ratio", COMPLIANT).fillna(
        of("ball_deflection_ratio", NONSMOOTH))
    disagree = np.abs(ratio - 1.0) > method_tol  # (NaN compares False)
    flagged = summary["peak_force_flagged"]
    summary["peak_force_flagged"] = xr.where(disagree, 1.0, flagged).where(paper.notnull())
    summary["method_ratio"] = ratio
    summary["static_deflection_ratio"] = deflection
    return summary


def _describe(summary: xr.Dataset) -> xr.Dataset:
    """units, long_name (a label; a longer text as ``comment``), flag attributes; no fill
    value on coordinates."""
    texts = {name: (units, text) for name, (_, _, units, text) in _VARIABLES.items()}
    texts.update({name: (units, text) for name, (_, units, text) in _GRID_VARIABLES.items()})
    for name, (units, text) in texts.items():
        summary[name].attrs.update(units=units, **label_attrs(text, _LABELS.get(name)))
    for name, (units, long_name) in _COORDS.items():
        summary[name].attrs.update(units=units, long_name=long_name)
        if name in _FLAGS:
            summary[name].attrs.update(
                flag_values=np.arange(len(_FLAGS[name]), dtype=np.int8),
                flag_meanings=" ".join(_FLAGS[name]))
    summary["model"].attrs["comment"] = ("nonsmooth: the paper's method (impulses, filter, "
                                         "Flores forces); compliant: Hertz contact forces")
    for name in summary.coords:
        summary[name].encoding["_FillValue"] = None
    return summary


def _per_model(files, what: str) -> dict:
    """{model name: [paths]} of a plain sequence (the nonsmooth runs) or of a mapping."""
    if isinstance(files, dict):
        bad = sorted(set(files) - set(MODELS))
        if bad:
            raise ValueError(f"summarize: {what} has the model {bad[0]!r}; allowed: "
                             f"{', '.join(MODELS)}")
        return {name: list(paths) for name, paths in files.items()}
    return {"nonsmooth": list(files)}


def _checked_settings(settings, settle, force_levels, method_tol) -> dict:
    """The analysis settings the numbers use, checked (one line naming the bad one)."""
    settings = dict(settings or {})
    settle = float(settings.get("settle", 0.0) if settle is None else settle)
    if not np.isfinite(settle) or settle < 0:
        raise ValueError(f"summarize: settle must be a number >= 0 [revolutions], got {settle}")
    force_levels = settings.get("force_levels", (100.0, 1000.0)) if force_levels is None \
        else force_levels
    levels = _levels(force_levels)
    if levels.size == 0 or not np.all(np.isfinite(levels) & (levels > 0)):
        raise ValueError(f"summarize: force_levels must be numbers > 0 [N], got {force_levels}")
    method_tol = float(settings.get("method_tol", 0.2) if method_tol is None else method_tol)
    if not (np.isfinite(method_tol) and method_tol > 0):
        raise ValueError(f"summarize: method_tol must be a number > 0, got {method_tol}")
    return dict(settings, settle=settle, force_levels=list(levels), method_tol=method_tol)


def summarize(run_files, impact_files, scheduler=None, num_workers: int | None = None,
              settle: float | None = None, force_levels: Sequence[float] | None = None,
              settings: dict | None = None, method_tol: float | None = None,
              models: Sequence[str] | None = None, axes: Sequence[str] | None = None,
              own_settings: Sequence[str] = ()) -> xr.Dataset:
    """Summarise a study over its swept parameters and its contact models.

    Parameters
    ----------
    run_files, impact_files : sequence of path, or {model name: sequence of path}
        The runs (or failed-run markers, attribute ``failed = 1``) and their tables, pairwise:
        a plain sequence holds nonsmooth runs; a mapping gives the files of each model
        (``{"nonsmooth": [...], "compliant": [...]}``). Nonsmooth tables have the dimension
        ``impact`` and columns ``time``, ``race``, ``kind``, ``F_max``, and where present
        ``p_max`` and ``flags`` (older tables with string ``race``/``kind`` are read too; a
        column a table lacks counts as missing). A model without tables (no key in
        ``impact_files``, e.g. compliant runs) has its numbers computed from its run files.
    scheduler : str, optional
        Where the numbers of runs whose tables do not carry them are computed: None or
        ``"threads"``: dask's local threads; ``"synchronous"``: no parallelism; ``"local"``: a
        new ``distributed.LocalCluster``; anything else: the address of a running dask
        distributed scheduler (``tcp://host:8786``), which needs the package ``distributed``
        and the files visible from its workers.
    num_workers : int, optional
        Local threads or local-cluster workers.
    settle, force_levels, method_tol : optional
        Start-up [crank revolutions], absolute force levels [N] and the tolerance of the
        method check [-]; default: those of ``settings`` (else 0, 100 N and 1 kN, 0.2).
    settings : dict, optional
        The ``analysis`` settings (``settle``, ``force_levels``, ``r_eff``,
        ``groove_conformity``, ``method_tol``), recorded as attributes ``analysis_<key>``.
    models : sequence of str, optional
        The models of the summary's ``model`` dimension, e.g. ``["nonsmooth", "compliant"]``
        (``study.models``); default: those with files.
    axes : sequence of str, optional
        The grid's axes (coordinate names, in order; ``study_axes``); default: every numeric
        scalar coordinate of the files, in the order of the first file.
    own_settings : sequence of str, optional
        ``analysis`` keys whose value each run takes from its own file (its attribute
        ``analysis.<key>``) instead of ``settings``: the study's swept analysis keys (a swept
        ``method_tol`` is then read per grid point from its axis ``analysis_method_tol``).

    Returns
    -------
    xarray.Dataset
        Dimensions: the grid's axes, ``model``, ``race``, ``kind``, ``level``, ``rank``,
        ``stage``; in memory, every variable with ``units`` and ``long_name`` (see the module
        docstring).
    """
    runs, tables = _per_model(run_files, "run_files"), _per_model(impact_files, "impact_files")
    if not any(runs.values()):
        raise ValueError("summarize: no run or impact files given")
    settings_in = settings
    settings = _checked_settings(settings, settle, force_levels, method_tol)
    pairs = []
    for name, paths in runs.items():
        paired = tables.get(name)
        if paired is not None and len(paired) != len(paths):
            raise ValueError(f"summarize: {name} runs and tables differ in number")
        pairs += list(zip(paths, paired if paired is not None else [None] * len(paths),
                          strict=True))
    wanted = sorted(MODELS.index(m) for m in (models if models else
                                              [m for m, p in runs.items() if p]))
    own = tuple(key for key in own_settings if key != "force_levels")  # (the level dimension)
    entries = _collect(pairs, settings, None if axes is None else list(axes), scheduler,
                       num_workers, own)
    entries = [entry for entry in entries if int(entry[1]["model"]) in wanted]
    summary = _assemble(entries, np.asarray(settings["force_levels"]), wanted, axes)
    # a failed run is missing everywhere for its model, whatever its impact table says
    failed = summary["failed"] > 0
    for name, (_, scope, _, _) in _VARIABLES.items():
        if name == "failed" or (scope != "model" and MODELS.index(scope) not in wanted):
            continue
        summary[name] = summary[name].where(
            ~(failed if scope == "model" else failed.sel(model=MODELS.index(scope), drop=True)))
    method_tol = settings["method_tol"]
    if "method_tol" in own and "analysis_method_tol" in summary.coords:
        method_tol = summary["analysis_method_tol"]  # (per grid point)
    summary = _across_models(summary, method_tol)
    grid = [d for d in summary.dims if d not in _ORDER]
    summary = _describe(summary.transpose(*grid, *[d for d in _ORDER if d in summary.dims]))
    _provenance(summary, settings["settle"], settings["method_tol"], settings_in or {}, own)
    return summary


def _provenance(summary: xr.Dataset, settle: float, method_tol: float, settings: dict,
                own=()) -> None:
    """The summary's global attributes: what made it, and the analysis settings every grid
    point shares (a swept one, in ``own``, is an axis, not an attribute)."""
    from simcore import __version__

    runs = summary["failed"].notnull()
    n_runs = int(runs.sum())
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    summary.attrs.update(
        Conventions="CF-1.10",
        title="Ball bearing in a crank-slider: parameter study summary",
        source=f"bearingsim {__version__} (analysis.summary)",
        history=f"{now}: summary of {n_runs} runs by bearingsim {__version__} "
                "(analysis.summary.summarize)",
        n_runs=n_runs,
        n_failed=int((summary["failed"] > 0).sum()),
    )
    shared = {"settle_revolutions": ("settle", settle), "method_tol": ("method_tol", method_tol)}
    for name, (key, value) in shared.items():
        if key not in own:
            summary.attrs[name] = value
    from simcore.io import setting_attribute

    for key, value in settings.items():
        if value is not None and key not in own:
            summary.attrs[f"analysis_{key}"] = setting_attribute(value)


# --- the study in one table -----------------------------------------------------------------

def _where(da: xr.DataArray, smallest: bool = False) -> str:
    """``clearance=0.0004, mu=0.05, ...`` of the largest (``smallest``: the smallest) finite
    value of ``da``."""
    values = np.asarray(da.values, dtype=float)
    if not np.isfinite(values).any():
        return ""
    idx = np.unravel_index((np.nanargmin if smallest else np.nanargmax)(values), values.shape)
    return ", ".join(f"{d}={_axis_value(da[d], i)}" for d, i in zip(da.dims, idx, strict=True))


def _axis_value(coord: xr.DataArray, i: int) -> str:
    """The value of a grid axis at index ``i``: a category's name (``flag_meanings``), else the
    number."""
    value = coord.values[i]
    names = str(coord.attrs.get("flag_meanings", "")).split()
    codes = list(np.asarray(coord.attrs.get("flag_values", range(len(names)))).ravel())
    if names and value in codes and len(codes) == len(names):
        return names[codes.index(value)]
    return f"{float(value):g}"


def _table_rows(summary: xr.Dataset, models: list[int]) -> list:
    """(quantity, unit, DataArray, scale) of the summary table, the models side by side
    (quantities the summary lacks are left out)."""
    rows = []
    both = len(models) > 1

    def of(name, m):
        return summary[name].sel(model=m) if "model" in summary[name].dims else summary[name]

    for name, what, unit, scale in (("peak_force", "steady peak force", "kN", 1e-3),
                                    ("peak_force_rev_median", "median over revolutions of the "
                                     "peak force", "kN", 1e-3),
                                    ("peak_force_rev_spread", "spread over revolutions of the "
                                     "peak force, (largest - smallest) / median", "1", 1.0),
                                    ("p_max", "peak contact pressure p_max", "MPa", 1e-6),
                                    ("p_max_groove", "peak contact pressure in a real groove",
                                     "MPa", 1e-6)):
        for r in (1, 0):
            for m in models if name in summary else ():
                rows.append((f"{what}, {RACES[r]} race, {MODELS[m]}", unit,
                             of(name, m).isel(race=r), scale))
    for r in (1, 0):
        if "method_ratio" in summary and both:
            rows.append((f"method ratio (nonsmooth / compliant peak), {RACES[r]} race", "1",
                         summary["method_ratio"].isel(race=r), 1.0))
    if "static_deflection_ratio" in summary and both:
        rows.append(("static deflection of a ball / clearance", "1",
                     summary["static_deflection_ratio"], 1.0))
    for m in models if "startup_peak_force" in summary else ():
        rows.append((f"start-up peak force, {MODELS[m]}", "kN", of("startup_peak_force", m),
                     1e-3))
    for i, level in enumerate(summary["level"].values if "above_per_rev" in summary else ()):
        for m in models:
            rows.append((f"{'impacts' if m == NONSMOOTH else 'contact episodes'} per "
                         f"revolution with force >= {level:g} N, {MODELS[m]}", "1",
                         of("above_per_rev", m).isel(level=i).sum("race", min_count=1), 1.0))
    if "impacts_per_rev" in summary and NONSMOOTH in models:
        rows.append(("impacts per revolution (nonsmooth, relative zero threshold)", "1",
                     summary["impacts_per_rev"].sum(["race", "kind"], min_count=1), 1.0))
    for name, what, unit in (("L10h", "rating life L10 (ISO 281), compliant", "h"),
                             ("L10rh", "reference rating life L10r (ball loads), compliant",
                              "h"),
                             ("static_safety_factor", "static safety factor s0 = C0 / P0 "
                              "(ISO 76), compliant", "1")):
        if name in summary and COMPLIANT in models:
            rows.append((what, unit, of(name, COMPLIANT), 1.0))
    if "revolutions" in summary:
        rows.append(("steady revolutions per run", "1", of("revolutions", models[0]), 1.0))
    if "iter_max" in summary and NONSMOOTH in models:
        rows.append(("Newton iterations per step, largest (any stage), nonsmooth", "1",
                     of("iter_max", NONSMOOTH).max("stage"), 1.0))
    for m in models if "wall_time_s" in summary else ():
        rows.append((f"wall time per run, {MODELS[m]}", "s", of("wall_time_s", m), 1.0))
    for m in models if "time_steps" in summary else ():
        rows.append((f"time steps per run, {MODELS[m]}", "1", of("time_steps", m), 1.0))
    for m in models if "rings_on_lands_fraction" in summary else ():
        rows.append((f"samples with the rings on their lands (bunched balls), {MODELS[m]}", "1",
                     of("rings_on_lands_fraction", m), 1.0))
    return rows


def summary_table(summary: xr.Dataset, model: str | None = None):
    """The study in numbers: each quantity's smallest, median and largest value over the grid,
    for both models and their ratio.

    Parameters
    ----------
    summary : xarray.Dataset
        Output of :func:`summarize`.
    model : {None, "nonsmooth", "compliant"}
        Only that model's rows; None (default): every model of the summary and their ratio.

    Returns
    -------
    pandas.DataFrame
        Columns ``quantity``, ``unit``, ``min``, ``median``, ``max``, ``largest at`` and
        ``smallest at`` (the grid points of the largest and the smallest value: for a life or
        a safety factor the smallest is the one to read); failed runs are left out (their
        values are missing).
    """
    import pandas as pd

    models = [int(m) for m in summary["model"].values] if "model" in summary.dims else [
        NONSMOOTH]
    if model is not None:
        if model not in MODELS or MODELS.index(model) not in models:
            raise ValueError(f"model: {model!r} is not allowed; allowed: None or one of "
                             + ", ".join(MODELS[m] for m in models))
        models = [MODELS.index(model)]
    failed = summary["failed"] > 0
    n_failed = int(failed.sum())
    grid = " x ".join(f"{summary.sizes[d]} {d}" for d in summary["failed"].dims if d != "model")
    rows = [{"quantity": f"runs, of which {n_failed} failed", "unit": "1", "min": "",
             "median": "", "max": str(int(summary["failed"].notnull().sum())),
             "largest at": f"grid: {grid}", "smallest at": ""}]
    if "peak_force_flagged" in summary:
        flagged = summary["peak_force_flagged"]
        rows.append({"quantity": "nonsmooth peak forces flagged (flag or method check)",
                     "unit": "1", "min": "", "median": "",
                     "max": f"{int((flagged > 0).sum())} of {int(flagged.notnull().sum())}",
                     "largest at": "", "smallest at": ""})
    for quantity, unit, da, scale in _table_rows(summary, models):
        values = np.asarray(da.values, dtype=float) * scale
        finite = values[np.isfinite(values)]
        if finite.size:
            rows.append({"quantity": quantity, "unit": unit, "min": f"{finite.min():.4g}",
                         "median": f"{np.median(finite):.4g}", "max": f"{finite.max():.4g}",
                         "largest at": _where(da), "smallest at": _where(da, smallest=True)})
    return pd.DataFrame(rows, columns=["quantity", "unit", "min", "median", "max",
                                       "largest at", "smallest at"])
