"""Impact extraction for one run: filter, classify, and turn each impact into a peak force.

SPEC sections 6, 7 and 9. One row per impact (dimension ``impact``): a *simple* impact where
Λ_FI exceeds the zero threshold, an impact on *persistent* contact where Λ_FIsuv exceeds it.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .filtering import impact_masks, split_impulses, zero_threshold
from .forces import _positive, hertz_stiffness, peak_force

__all__ = ["extract_impacts", "top_forces", "run_geometry", "STUDY_PARAMETERS"]

STUDY_PARAMETERS = ("clearance", "mu", "omega0", "e_N")

_VARS = {
    "contact": ("", "contact index (balls 0..n-1 on the inner race, then on the outer race)"),
    "ball": ("", "ball index"),
    "race": ("", "race of the contact (inner | outer)"),
    "time": ("s", "time of the impact step (end of the step)"),
    "kind": ("", "impact kind: simple (isolated) | persistent (on persistent contact)"),
    "impulse": ("N s", "impact impulse (Lambda_FI or Lambda_FIsuv)"),
    "v_pre": ("m s-1", "approach speed before the impact (-vn_pre)"),
    "approach": ("1", "1 where v_pre > v_min (Flores force computed), 0 otherwise"),
    "m_eff": ("kg", "effective mass impulse / ((1 + e_N) v_pre)"),
    "F_static": ("N", "static contact force before the impact, Lambda_S / h (0 if simple)"),
    "K": ("N m-1.5", "Hertz stiffness of the contact"),
    "F_max": ("N", "peak Flores contact force (missing where v_pre <= v_min)"),
    "delta_max": ("m", "largest indentation during the impact (total)"),
    "contact_time": ("s", "duration of the Flores impact"),
    "v_rebound": ("m s-1", "speed at the end of the Flores impact (separating)"),
}


def _model_value(run_ds: xr.Dataset, key: str) -> float:
    """A model setting: the scalar coordinate if present, else attrs['model.<key>']."""
    if key in run_ds.coords and run_ds[key].ndim == 0:
        return float(run_ds[key].values)
    name = f"model.{key}"
    if name in run_ds.attrs:
        return float(run_ds.attrs[name])
    raise ValueError(f"run dataset lacks the setting {name!r} (attribute) needed by the analysis")


def _time_step(run_ds: xr.Dataset) -> float:
    if "solver.dt" in run_ds.attrs:
        return float(run_ds.attrs["solver.dt"])
    t = np.asarray(run_ds["time"].values, dtype=float)
    if t.size < 2:
        raise ValueError("run dataset lacks attribute 'solver.dt' and has < 2 time samples")
    return float(np.median(np.diff(t)))


def run_geometry(run_ds: xr.Dataset, r_eff: str = "concave") -> dict:
    """Radii, material and Hertz stiffness of the two races of a run.

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run (SPEC section 5), with attrs ``model.ball_radius``, ``model.inner_radius``,
        ``model.youngs_modulus``, ``model.poisson_ratio`` and the clearance (scalar coordinate or
        ``model.clearance``).
    r_eff : {"concave", "paper"}
        Effective radius of the outer-race contact: ``"concave"`` r_B r_C/(r_C - r_B) (correct for
        a ball inside the race) or ``"paper"`` r_B r_C/(r_B + r_C) (the paper's printed form).

    Returns
    -------
    dict
        ``ball_radius``, ``inner_radius``, ``outer_radius`` [m], ``E`` [Pa], ``nu`` [-],
        ``K_inner``, ``K_outer`` [N/m^1.5].
    """
    if r_eff not in ("concave", "paper"):
        raise ValueError(f"r_eff must be 'concave' or 'paper', got {r_eff!r}")
    r_b = _model_value(run_ds, "ball_radius")
    r_a = _model_value(run_ds, "inner_radius")
    g = _model_value(run_ds, "clearance")
    E = _model_value(run_ds, "youngs_modulus")
    nu = _model_value(run_ds, "poisson_ratio")
    r_c = r_a + 2.0 * r_b + g
    return {
        "ball_radius": r_b,
        "inner_radius": r_a,
        "outer_radius": r_c,
        "E": E,
        "nu": nu,
        "K_inner": hertz_stiffness(r_b, r_a, E, nu, E, nu, concave=False),
        "K_outer": hertz_stiffness(r_b, r_c, E, nu, E, nu, concave=(r_eff == "concave")),
    }


def extract_impacts(run_ds: xr.Dataset, zero_tol=1e-4, zero_floor=1e-12, r_eff="concave",
                    v_min=1e-3) -> xr.Dataset:
    """Table of the impacts of one run with their Flores peak forces.

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run (SPEC section 5): ``Lambda_N`` and ``vn_pre`` (time, contact), coordinates
        ``ball`` and ``race`` on ``contact``, model settings in attrs (see :func:`run_geometry`),
        ``solver.dt`` (else the median time step) and e_N (scalar coordinate or ``model.e_N``).
    zero_tol : float
        Relative zero threshold of the filter [-]; the scale is the run's largest Λ_N.
    zero_floor : float
        Absolute floor of the zero threshold [N s].
    r_eff : {"concave", "paper"}
        Effective radius of the outer-race contacts (:func:`run_geometry`).
    v_min : float
        Smallest approach speed for a Flores force [m/s]. Impacts with v_pre <= v_min stay in the
        table with ``approach = 0`` and F_max, m_eff, delta_max, contact_time missing (NaN).

    Returns
    -------
    xarray.Dataset
        Dimension ``impact`` (sorted by time, then contact) with variables contact, ball, race,
        time, kind, impulse, v_pre, approach, m_eff, F_static, K, F_max, delta_max, contact_time,
        v_rebound; the run's scalar coordinates (clearance, mu, omega0, e_N); attrs with the
        threshold used (``zero_threshold`` [N s]), ``r_eff``, ``v_min``, ``E``, ``nu``, radii,
        stiffnesses and the counts ``n_simple``, ``n_persistent``, ``n_no_approach``.
    """
    for name in ("Lambda_N", "vn_pre"):
        if name not in run_ds:
            raise ValueError(f"run dataset has no variable {name!r}")
    v_min = _positive("v_min", v_min)
    geo = run_geometry(run_ds, r_eff)
    e_N = _model_value(run_ds, "e_N")
    h = _time_step(run_ds)

    lam = np.asarray(run_ds["Lambda_N"].transpose("contact", "time").values, dtype=float)
    vn_pre = np.asarray(run_ds["vn_pre"].transpose("contact", "time").values, dtype=float)
    scale = max(float(np.max(lam)), 0.0) if lam.size else 0.0
    thr = zero_threshold(scale=scale, zero_tol=zero_tol, floor=zero_floor)
    fi, s, fisuv = split_impulses(lam, zero_tol, zero_floor, scale=scale)
    simple, persistent = impact_masks(fi, fisuv, thr)

    contacts = np.asarray(run_ds["contact"].values)
    balls = (np.asarray(run_ds["ball"].values) if "ball" in run_ds.coords
             else np.full(contacts.shape, -1))
    races = (np.asarray(run_ds["race"].values).astype(str) if "race" in run_ds.coords
             else np.full(contacts.shape, "unknown"))
    times = np.asarray(run_ds["time"].values, dtype=float)

    ci_s, ti_s = np.nonzero(simple)
    ci_p, ti_p = np.nonzero(persistent)
    ci = np.concatenate([ci_s, ci_p]).astype(np.int64)
    ti = np.concatenate([ti_s, ti_p]).astype(np.int64)
    is_simple = np.concatenate([np.ones(ci_s.size, bool), np.zeros(ci_p.size, bool)])
    order = np.lexsort((ci, ti))
    ci, ti, is_simple = ci[order], ti[order], is_simple[order]
    n = ci.size

    impulse = np.where(is_simple, fi[ci, ti], fisuv[ci, ti])
    v_pre = -vn_pre[ci, ti]
    F_static = np.where(is_simple, 0.0, s[ci, ti] / h)
    race = races[ci]
    K = np.where(race == "outer", geo["K_outer"], geo["K_inner"]).astype(float)
    approach = np.isfinite(v_pre) & (v_pre > v_min)
    # the Flores law has no meaning for e_N = 0 (D ~ (1 - e_N)/e_N): such a run keeps its
    # impacts in the table, every F_max missing, as for an impact without approach
    flores = e_N > 0.0
    m_eff = np.full(n, np.nan)
    F_max = np.full(n, np.nan)
    delta_max = np.full(n, np.nan)
    contact_time = np.full(n, np.nan)
    v_rebound = np.full(n, np.nan)
    for k in np.flatnonzero(approach & flores):
        res = peak_force(impulse[k], v_pre[k], e_N, K[k], F_static=max(F_static[k], 0.0), h=h,
                         details=True)
        m_eff[k] = res.m_eff
        F_max[k] = res.F_max
        delta_max[k] = res.delta_max
        contact_time[k] = res.contact_time
        v_rebound[k] = res.v_rebound

    data = {
        "contact": contacts[ci].astype(np.int64),
        "ball": balls[ci].astype(np.int64),
        "race": race.astype(str),
        "time": times[ti],
        "kind": np.where(is_simple, "simple", "persistent").astype(str),
        "impulse": impulse,
        "v_pre": v_pre,
        "approach": approach.astype(np.int8),
        "m_eff": m_eff,
        "F_static": F_static,
        "K": K,
        "F_max": F_max,
        "delta_max": delta_max,
        "contact_time": contact_time,
        "v_rebound": v_rebound,
    }
    ds = xr.Dataset(coords={"impact": ("impact", np.arange(n, dtype=np.int64))})
    for name, values in data.items():
        units, long_name = _VARS[name]
        attrs = {"long_name": long_name}
        if units:
            attrs["units"] = units
        ds[name] = ("impact", values, attrs)
    for name, coord in run_ds.coords.items():
        if coord.ndim == 0:
            ds = ds.assign_coords({name: coord.variable})
    ds.attrs.update({
        "title": "impacts of one run (Flores et al. 2011 peak forces)",
        "zero_tol": float(zero_tol),
        "zero_floor": float(zero_floor),
        "zero_threshold": float(thr),
        "zero_threshold_units": "N s",
        "lambda_scale": scale,
        "r_eff": r_eff,
        "v_min": v_min,
        "e_N": e_N,
        "h": h,
        "E": geo["E"],
        "nu": geo["nu"],
        "ball_radius": geo["ball_radius"],
        "inner_radius": geo["inner_radius"],
        "outer_radius": geo["outer_radius"],
        "K_inner": geo["K_inner"],
        "K_outer": geo["K_outer"],
        "n_simple": int(is_simple.sum()),
        "n_persistent": int((~is_simple).sum()),
        "n_no_approach": int((~approach).sum()),
    })
    if "title" in run_ds.attrs:
        ds.attrs["run_title"] = str(run_ds.attrs["title"])
    return ds


def top_forces(impacts_ds: xr.Dataset, n=3, race="outer") -> xr.Dataset:
    """The ``n`` largest peak forces of an impact table.

    Parameters
    ----------
    impacts_ds : xarray.Dataset
        Output of :func:`extract_impacts`.
    n : int
        How many.
    race : {"outer", "inner", None}
        Restrict to one race (None: all contacts).

    Returns
    -------
    xarray.Dataset
        The selected rows, largest F_max first (impacts without a force are skipped).
    """
    ds = impacts_ds
    mask = np.isfinite(ds["F_max"].values)
    if race is not None:
        mask &= ds["race"].values.astype(str) == race
    idx = np.flatnonzero(mask)
    idx = idx[np.argsort(-ds["F_max"].values[idx], kind="stable")][:n]
    return ds.isel(impact=idx)
