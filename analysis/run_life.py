"""Rating lives of the bearing from a compliant run's ball loads over its steady window.

The formulas and their sources are in :mod:`analysis.life` (docs/life.md). This module reads
what they need from a compliant run file:

* **load samples.** The contact force of each ball on each race, taken as the mean over each
  output interval, ``Lambda_N / output interval`` (the impulse of the interval, ∫F dt): the
  load history at the file's resolution. (``F_N``, the largest force of each interval, would
  count a 30 µs impact peak for the whole interval.)
* **where the balls are.** The inner race turns with the crank about the crank pin,
  A = L1 (cos θ, sin θ) with θ the crank angle; the outer race is the rod's big end, its centre
  A + (``journal_x``, ``journal_y``), turning with the rod's ``angle``. A ball's angle in a race's
  own frame is the direction from the race's centre to the ball (``position``) less the race's
  rotation.
* **the transmitted radial load** F_r(t) = |Σ_j F_j n_j| over the inner-race contacts (n_j from
  the pin towards ball j): the pin reaction the bearing carries.

ISO 281 ``L10`` = (C / P)^3 with P the cubic mean of F_r weighted by the crank revolutions made
under each sample (the relative revolution of the rings over a crank revolution is exactly one).
``L10r`` combines the Lundberg-Palmgren lives of both raceways computed by counting the balls
that roll over each raceway element (:func:`analysis.life.reference_life_history`). Hours at the
mean crank speed of the window (omega0 under the constant drive).

C: ``analysis.life_load_rating`` where given, else the catalogue's C of ``model.bearing`` where
the run names an entry that has one, else Lundberg and Palmgren's C of the modelled ring
(:func:`analysis.life.bearing_capacity_lp`) from its ball diameter, pitch diameter, ball count
and the groove conformities (:func:`conformities`: ``analysis.life_conformity``, else the run's
``model.inner_conformity`` and ``model.outer_conformity``, which are the catalogue entry's
typical values or else 0.52 and 0.53; catalogues do not publish a bearing's own).

ISO 76: ``static_safety_factor`` s0 = C0 / P0 with P0 the largest F_r of the window and C0 the
catalogue's static rating of ``model.bearing``, else the one its definition gives the modelled
ring (:func:`analysis.life.static_load_rating`).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from . import life
from .reads import run_setting

__all__ = ["compliant_life", "ring_geometry", "conformities", "LIFE_NAMES",
           "DEFAULT_CONFORMITY"]


def _schema_conformities() -> tuple[float, float]:
    from simcore.config import schema_default

    return (float(schema_default("model", "inner_conformity")),
            float(schema_default("model", "outer_conformity")))


#: Groove radius over ball diameter, inner and outer race, of a file that does not record them:
#: the defaults of ``model.inner_conformity`` and ``model.outer_conformity`` (0.52, 0.53, the
#: usual values of deep-groove ball bearings, docs/life.md).
DEFAULT_CONFORMITY = _schema_conformities()
#: The model settings :func:`compliant_life` needs of a run file.
GEOMETRY_SETTINGS = ("ball_radius", "inner_radius", "n_balls", "crank_length")
#: The numbers :func:`compliant_life` returns.
LIFE_NAMES = ("L10", "L10r", "L10h", "L10rh", "equivalent_load", "load_rating",
              "static_load_rating", "static_equivalent_load", "static_safety_factor")


def _catalogue_entry(run_ds: xr.Dataset) -> dict:
    """The catalogue entry the run names (``model.bearing``), else an empty one."""
    name = run_setting(run_ds, "bearing", None)
    if name is None:
        return {}
    from simcore.model.bearing import bearing

    return bearing(str(name))


def conformities(run_ds: xr.Dataset, settings: dict) -> tuple[float, float]:
    """Groove radius over ball diameter of the inner and the outer race [-]: the settings'
    ``life_conformity`` where given, else the run's ``model.inner_conformity`` and
    ``model.outer_conformity``, else (files that lack them) the catalogue entry's ``f_i``,
    ``f_e`` where the run names a bearing that gives them, else :data:`DEFAULT_CONFORMITY`."""
    return _conformities(settings, _catalogue_entry(run_ds), run_ds)


def _conformities(settings: dict, entry: dict, run_ds=None) -> tuple[float, float]:
    """:func:`conformities` from the run's catalogue ``entry`` (:func:`_catalogue_entry`)."""
    given = settings.get("life_conformity")
    if given is not None:
        f_i, f_e = given
        return float(f_i), float(f_e)
    if run_ds is not None:
        f_i = run_setting(run_ds, "inner_conformity", None)
        f_e = run_setting(run_ds, "outer_conformity", None)
        if f_i is not None and f_e is not None:
            return float(f_i), float(f_e)
    if entry.get("f_i") is not None and entry.get("f_e") is not None:
        return float(entry["f_i"]), float(entry["f_e"])
    return DEFAULT_CONFORMITY


def ring_geometry(run_ds: xr.Dataset, settings: dict) -> dict:
    """Ball diameter, pitch diameter [m], ball count, conformities (:func:`conformities`) and
    the raceway capacities Q_ci, Q_ce [N], C [N] (with where C comes from) and C0 [N] of a run's
    bearing."""
    r_b, r_a = float(run_setting(run_ds, "ball_radius")), float(run_setting(run_ds, "inner_radius"))
    n_balls = int(run_setting(run_ds, "n_balls"))
    entry = _catalogue_entry(run_ds)
    f_i, f_e = _conformities(settings, entry, run_ds)
    D_w, D_pw = 2.0 * r_b, 2.0 * (r_a + r_b)
    Q_ci = life.raceway_capacity(D_w, D_pw, f_i, n_balls, "inner")
    Q_ce = life.raceway_capacity(D_w, D_pw, f_e, n_balls, "outer")
    C, source = settings.get("life_load_rating"), "analysis.life_load_rating"
    if C is None:
        C, source = entry.get("C"), "catalogue"
    if C is None:
        C, source = life.bearing_capacity_lp(Q_ci, Q_ce, n_balls), "Lundberg-Palmgren"
    C0 = entry.get("C0")
    if C0 is None:
        C0 = life.static_load_rating(D_w, D_pw, n_balls, f_i, f_e)
    return {"D_w": D_w, "D_pw": D_pw, "n_balls": n_balls, "conformity": (f_i, f_e),
            "Q_ci": Q_ci, "Q_ce": Q_ce, "C": float(C), "C_source": source, "C0": float(C0)}


def _stored(values) -> np.ndarray:
    """Values at the precision the run file stores them (float32), so that a run in memory and
    its file give the same lives."""
    return np.asarray(values).astype(np.float32).astype(np.float64)


def _ball_frames(run_ds: xr.Dataset, n_balls: int):
    """Per sample: unit vectors pin -> ball (n, Z, 2), ball angles in the inner and the outer
    race's frames (n, Z) [rad]."""
    theta = np.asarray(run_ds["crank_angle"].values, dtype=float)
    L1 = float(run_setting(run_ds, "crank_length"))
    pin = L1 * np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    big_end = pin + np.stack([_stored(run_ds["journal_x"].values),
                              _stored(run_ds["journal_y"].values)], axis=-1)
    bodies = [str(b) for b in run_ds["body"].values]
    balls = [bodies.index(f"ball{j}") for j in range(n_balls)]
    position = _stored(run_ds["position"].transpose("time", "body", "axis").values)[:, balls, :]
    rod_angle = _stored(run_ds["angle"].transpose("time", "body").values)[:, bodies.index("rod")]
    to_ball = position - pin[:, None, :]
    normal = to_ball / np.linalg.norm(to_ball, axis=-1, keepdims=True)
    from_big_end = position - big_end[:, None, :]
    psi_inner = np.arctan2(to_ball[..., 1], to_ball[..., 0]) - theta[:, None]
    psi_outer = np.arctan2(from_big_end[..., 1], from_big_end[..., 0]) - rod_angle[:, None]
    return normal, psi_inner, psi_outer


def compliant_life(run_ds: xr.Dataset, settle_time: float, settings: dict) -> dict:
    """Rating lives of a compliant run's bearing over its steady window.

    Parameters
    ----------
    run_ds : xarray.Dataset
        A compliant run with ``Lambda_N`` (time, contact), ``race`` and ``ball`` on ``contact``,
        ``crank_angle``, ``journal_x``, ``journal_y``, ``position`` and ``angle`` (of the
        balls and the rod), ``output_interval_s`` and the model's attributes.
    settle_time : float
        End of the start-up [s]; the window is the samples after it.
    settings : dict
        ``life_conformity`` ([f_i, f_e]) and ``life_load_rating`` (C [N] or None), where given.

    Returns
    -------
    dict of float
        ``L10``, ``L10r`` [10^6 rev], ``L10h``, ``L10rh`` [h], ``equivalent_load`` P [N],
        ``load_rating`` C [N], ``static_load_rating`` C0 [N] (the catalogue's where the run
        names a bearing that has one, else :func:`analysis.life.static_load_rating`),
        ``static_equivalent_load`` P0, the largest transmitted radial load of the window [N],
        and ``static_safety_factor`` s0 = C0 / P0 (ISO 76); NaN where the window holds fewer
        than two samples or the crank does not turn.
    """
    geo = ring_geometry(run_ds, settings)
    nan = dict.fromkeys(LIFE_NAMES, np.nan)
    nan["load_rating"], nan["static_load_rating"] = geo["C"], geo["C0"]
    time = np.asarray(run_ds["time"].values, dtype=float)
    steady = time > settle_time
    theta = np.asarray(run_ds["crank_angle"].values, dtype=float)
    if steady.sum() < 2:
        return nan
    Z = geo["n_balls"]
    races = np.asarray(run_ds["race"].values).astype(str)
    balls = np.asarray(run_ds["ball"].values).astype(int)
    interval = float(run_ds.attrs.get("output_interval_s", np.median(np.diff(time))))
    impulse = np.asarray(run_ds["Lambda_N"].transpose("time", "contact").values, dtype=float)
    load = {race: np.zeros((time.size, Z)) for race in ("inner", "outer")}
    for c, (race, ball) in enumerate(zip(races, balls, strict=True)):
        load[race][:, ball] = np.maximum(impulse[:, c], 0.0) / interval
    normal, psi_inner, psi_outer = _ball_frames(run_ds, Z)
    F_r = np.linalg.norm(np.einsum("nz,nzk->nk", load["inner"], normal), axis=-1)
    t, F_r = time[steady], F_r[steady]
    revolutions = abs(theta[steady][-1] - theta[steady][0]) / (2.0 * np.pi)
    if not revolutions > 0:
        return nan
    speed = 2.0 * np.pi * revolutions / (t[-1] - t[0])
    P = life.equivalent_load(F_r, life.revolution_weights(t, speed))
    L10 = life.basic_rating_life(geo["C"], P)
    lives = {}
    for race, psi, Q_c in (("inner", psi_inner, geo["Q_ci"]), ("outer", psi_outer, geo["Q_ce"])):
        u = life.reference_cycles_per_revolution(geo["D_w"], geo["D_pw"], Z, race)
        lives[race], _ = life.reference_life_history(load[race][steady], psi[steady],
                                                     revolutions, Q_c, u)
    L10r = life.combine_races(lives["inner"], lives["outer"])
    P0 = float(F_r.max())  # the largest transmitted load: ISO 76's P0 of a pure radial load
    return {"L10": L10, "L10r": L10r, "L10h": life.life_hours(L10, speed),
            "L10rh": life.life_hours(L10r, speed), "equivalent_load": P,
            "load_rating": geo["C"], "static_load_rating": geo["C0"],
            "static_equivalent_load": P0,
            "static_safety_factor": np.inf if P0 == 0.0 else geo["C0"] / P0}
