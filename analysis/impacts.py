"""Impact extraction for one run: filter, classify by kind, peak force, stresses and flags.

docs/forces.md; the formulas per kind and what they rest on are in
``docs/forces.md``. One row per impact (dimension ``impact``): where Λ_FI (a simple impact) or
Λ_FIsuv (an impact on persistent contact) exceeds the zero threshold. Each row then gets a
*kind* from the data:

* ``pinch``: the ball's other contact (same ball, other race) carries impulse in the same step
  or within one step of it. The ball is squeezed between the two races: the impact is the races
  approaching each other along the ball's line, at the speed
  v_pre = -(vn_inner + vn_outer) (a 2.7 g ball between kilogram bodies carries no momentum of
  its own worth counting), through two Hertz contacts in series,
  K = (K_in^{-2/3} + K_out^{-2/3})^{-3/2}.
* ``multi``: not a pinch, but several balls carry impulse in that step.
* ``persistent``: an impact on top of persistent contact (F_static = Λ_S/h > 0).
* ``simple``: an isolated impact of a single ball on one race.

The normal velocity of every kind is that *before the velocity jump of the impact step*,
``vn_free`` = G_N(q_{n+1}) ṽ_{n+1} (after the smooth step and the position correction). A run
file without it falls back to ``vn_pre`` (start of the step) and says so in the attribute
``v_pre_source``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from simcore.io.variables import label_attrs

from ._checks import positive
from .contact_stress import contact_modulus, elliptical_contact, groove_radii, hertz_circular
from .filtering import impact_masks, split_impulses, zero_threshold
from .forces import effective_radius, hertz_stiffness, peak_forces
from .reads import run_setting

__all__ = ["extract_impacts", "top_forces", "loaded_stretches", "run_geometry",
           "series_stiffness", "STUDY_PARAMETERS", "race_name", "kind_name", "flag_names",
           "stiffness", "count_flags", "race_codes", "race_stresses", "KIND", "RACE", "FLAG"]

STUDY_PARAMETERS = ("clearance", "mu", "omega0", "e_N")
_PARAM_ATTRS = {
    "clearance": ("m", "radial clearance"),
    "mu": ("1", "friction coefficient"),
    "omega0": ("rad s-1", "crank speed"),
    "e_N": ("1", "normal restitution coefficient"),
}

KIND = {"simple": 0, "persistent": 1, "pinch": 2, "multi": 3}
RACE = {"inner": 0, "outer": 1}
FLAG = {
    "no_approach": 1,          # v_pre <= v_min: no Flores force
    "e_N_zero": 2,             # e_N = 0: the Flores damping is undefined, no force
    "contact_long": 4,         # Hertz contact time > contact_long_ratio * dt
    "not_converged_dt": 8,     # moved by more than the tolerance at dt/2 (dt-check)
    "solver_unconverged": 16,  # the solver step of the impact did not converge
    "method_disagrees": 32,    # a compliant zoom's force differs by more than method_tol
    "peak_at_onset": 64,       # on a loaded contact the largest force is the start's F_s (1 + c)
}

_BALL_FACTOR = 2.0  # a pinch impulse exceeds twice what the ball alone can carry

# name: (units or None, long_name[, label where long_name is longer than a label])
_VARS = {
    "contact": ("1", "contact index (balls 0..n-1 on the inner race, then on the outer race)"),
    "ball": ("1", "ball index"),
    "race": (None, "race of the contact"),
    "time": ("s", "time of the impact step (end of the step)"),
    "kind": (None, "impact kind"),
    "impulse": ("N s", "impact impulse of this contact (Lambda_FI or Lambda_FIsuv)"),
    "v_pre": ("m s-1", "approach speed of the impact (pinch: of the two races along the ball)"),
    "approach": ("1", "1 where v_pre > v_min (Flores force computed), 0 otherwise"),
    "m_eff": ("kg", "effective mass impulse / ((1 + e_N) v_pre)"),
    "F_static": ("N", "static contact force before the impact, Lambda_S / h (0 if none)"),
    "K": ("N2 m-3", "square of the contact stiffness K of F = K delta^1.5 (pinch: the series "
                    "stiffness), because UDUNITS has no fractional powers: K itself [N m-1.5] is "
                    "its square root (analysis.impacts.stiffness)",
          "square of the Hertz contact stiffness"),
    "F_max": ("N", "peak Flores contact force (missing where flagged no_approach or e_N_zero)"),
    "delta_max": ("m", "Hertz indentation of this contact under F_max"),
    "contact_radius": ("m", "Hertz contact radius under F_max (ellipse: semi-major axis)"),
    "contact_semi_minor": ("m", "semi-minor axis of the contact under F_max (= contact_radius "
                                "for the circular contact)",
                           "semi-minor axis of the contact under F_max"),
    "p_max": ("Pa", "largest Hertz contact pressure under F_max, 3 F / (2 pi a b)"),
    "contact_time": ("s", "duration of the Flores impact"),
    "contact_time_steps": ("1", "contact_time / dt"),
    "v_rebound": ("m s-1", "speed at the end of the Flores impact (separating)"),
    "flags": (None, "why the force of this impact is not to be trusted (bit mask)"),
    "trusted": (None, "1 where F_max exists and no flag is set"),
}


def _model_value(run_ds: xr.Dataset, key: str) -> float:
    """A numeric model setting of a run (:func:`~analysis.reads.run_setting`), required."""
    return float(run_setting(run_ds, key))


def _time_step(run_ds: xr.Dataset) -> float:
    """Interval of the impulse series [s]: the output interval of a sampled (compliant) run,
    else the solver step."""
    if "output_interval_s" in run_ds.attrs:
        return float(run_ds.attrs["output_interval_s"])
    if "solver.dt" in run_ds.attrs:
        return float(run_ds.attrs["solver.dt"])
    t = np.asarray(run_ds["time"].values, dtype=float)
    if t.size < 2:
        raise ValueError("run dataset lacks attribute 'solver.dt' and has < 2 time samples")
    return float(np.median(np.diff(t)))


def series_stiffness(K1, K2) -> float:
    """Stiffness of two Hertz contacts F = K_i δ_i^{3/2} in series [N m-1.5].

    The same force passes both: δ = δ1 + δ2 = (F/K1)^{2/3} + (F/K2)^{2/3} = (F/K)^{2/3} with
    K = (K1^{-2/3} + K2^{-2/3})^{-3/2}.
    """
    K1 = positive("K1", K1)
    K2 = positive("K2", K2)
    return (K1 ** (-2.0 / 3.0) + K2 ** (-2.0 / 3.0)) ** -1.5


def run_grooves(run_ds: xr.Dataset) -> tuple[float, float] | None:
    """The groove conformities (f_i, f_e) [-] of a run whose ball-race contacts are elliptical
    (attribute ``model.contact_geometry`` = ``groove``, conformities from
    ``model.inner_conformity`` and ``model.outer_conformity``); None for the in-plane
    contacts (``plane``, or a file that does not say)."""
    if str(run_setting(run_ds, "contact_geometry", "plane")) != "groove":
        return None
    return (_model_value(run_ds, "inner_conformity"), _model_value(run_ds, "outer_conformity"))


def run_geometry(run_ds: xr.Dataset, r_eff: str = "concave", groove_conformity=None) -> dict:
    """Radii, material and contact stiffness of the two races of a run.

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run file's dataset, with attrs ``model.ball_radius``, ``model.inner_radius``,
        ``model.youngs_modulus``, ``model.poisson_ratio`` and the clearance (scalar coordinate or
        ``model.clearance``).
    r_eff : {"concave", "paper"}
        Effective radius of the outer-race contact: ``"concave"`` r_B r_C/(r_C - r_B) (correct for
        a ball inside the race) or ``"paper"`` r_B r_C/(r_B + r_C) (the paper's printed form).
        Not used with a groove conformity.
    groove_conformity : float, (float, float) or None
        Groove radius over ball diameter (e.g. 0.52), one for both races or (inner, outer):
        elliptical Hertz contacts. None: the run's own contacts, the in-plane spheres
        (circular Hertz) or, where its ``model.contact_geometry`` is ``groove``, its grooves
        (:func:`run_grooves`).

    Returns
    -------
    dict
        ``ball_radius``, ``inner_radius``, ``outer_radius`` [m], ``E`` [Pa], ``nu`` [-],
        ``E_star`` [Pa], ``K_inner``, ``K_outer``, ``K_pinch`` [N m-1.5], ``stress``: a
        function (F [N], race code) -> (a, b, delta, p_max), and ``contacts``: ``"plane"`` or
        ``"groove f_i f_e"``, the contacts these come from.
    """
    if r_eff not in ("concave", "paper"):
        raise ValueError(f"r_eff must be 'concave' or 'paper', got {r_eff!r}")
    r_b = _model_value(run_ds, "ball_radius")
    r_a = _model_value(run_ds, "inner_radius")
    g = _model_value(run_ds, "clearance")
    E = _model_value(run_ds, "youngs_modulus")
    nu = _model_value(run_ds, "poisson_ratio")
    r_c = r_a + 2.0 * r_b + g
    E_star = contact_modulus(E, nu)
    if groove_conformity is None:
        groove_conformity = run_grooves(run_ds)
    if groove_conformity is None:
        R = {0: effective_radius(r_b, r_a), 1: effective_radius(r_b, r_c, r_eff == "concave")}
        K_in = hertz_stiffness(r_b, r_a, E, nu, E, nu, concave=False)
        K_out = hertz_stiffness(r_b, r_c, E, nu, E, nu, concave=(r_eff == "concave"))

        def stress(F, race):
            a, d, p = hertz_circular(F, R[race], E_star)
            return a, a, d, p
        contacts = "plane"
    else:
        f_in, f_out = (groove_conformity, groove_conformity) if np.ndim(groove_conformity) == 0 \
            else groove_conformity
        ell = {0: elliptical_contact(*groove_radii(r_b, r_a, f_in, "inner"), E_star),
               1: elliptical_contact(*groove_radii(r_b, r_c, f_out, "outer"), E_star)}
        K_in, K_out = ell[0].K, ell[1].K

        def stress(F, race):
            return ell[race].at(F)
        contacts = f"groove {float(f_in):g} {float(f_out):g}"
    return {
        "ball_radius": r_b,
        "inner_radius": r_a,
        "outer_radius": r_c,
        "E": E,
        "nu": nu,
        "E_star": E_star,
        "K_inner": K_in,
        "K_outer": K_out,
        "K_pinch": series_stiffness(K_in, K_out),
        "stress": stress,
        "contacts": contacts,
    }


def race_codes(run_ds, n_contacts: int) -> np.ndarray:
    """Race code (:data:`RACE`) of each contact, from the run's coordinate ``race`` (names or
    codes); a ``ValueError`` when it is missing, holds other names or has not ``n_contacts``."""
    if "race" not in run_ds.coords:
        raise ValueError("run dataset has no coordinate 'race' on 'contact'")
    raw = np.asarray(run_ds["race"].values)
    if raw.dtype.kind in "iu":
        codes = raw.astype(np.int8)
    else:
        names = raw.astype(str)
        bad = sorted(set(names) - set(RACE))
        if bad:
            raise ValueError(f"race values must be 'inner' or 'outer', got {bad}")
        codes = np.array([RACE[s] for s in names], dtype=np.int8)
    if codes.size != n_contacts:
        raise ValueError("coordinate 'race' does not match dimension 'contact'")
    return codes


def _partners(balls, races):
    """Index of the contact of the same ball on the other race (-1 if none)."""
    out = np.full(balls.size, -1, dtype=np.int64)
    lookup = {(int(b), int(r)): i for i, (b, r) in enumerate(zip(balls, races, strict=True))}
    for i, (b, r) in enumerate(zip(balls, races, strict=True)):
        out[i] = lookup.get((int(b), 1 - int(r)), -1)
    return out


def _set_attrs(name, units_long):
    units, long_name = units_long[:2]
    attrs = label_attrs(long_name, units_long[2] if len(units_long) > 2 else None)
    if units is not None:
        attrs["units"] = units
    return attrs


# --- extract_impacts in named stages ---------------------------------------------------------

@dataclass
class _Series:
    """The arrays of a run that the impact extraction reads (contact-major)."""

    lam: np.ndarray        # Lambda_N (contact, time) [N s]
    vn: np.ndarray         # normal velocity before the jump (contact, time) [m/s]
    times: np.ndarray      # (time,) [s]
    step_ok: np.ndarray    # (time,) bool: every sub-problem of the step converged
    contacts: np.ndarray   # contact labels
    balls: np.ndarray      # ball of each contact
    races: np.ndarray      # race code of each contact (RACE)
    partner: np.ndarray    # the same ball's contact on the other race (-1 if none)


@dataclass
class _Filtered:
    """The impulse filter's split of every contact and the threshold it used."""

    fi: np.ndarray         # simple impacts Lambda_FI (contact, time) [N s]
    s: np.ndarray          # smooth part Lambda_S [N s]
    fisuv: np.ndarray      # impacts on persistent contact Lambda_FIsuv [N s]
    threshold: float       # zero threshold [N s]
    scale: float           # the run's largest Lambda_N [N s]
    loaded: np.ndarray     # Lambda_N above the threshold (contact, time)


@dataclass
class _Rows:
    """One entry per impact row: contact and step index, filter class, kind."""

    ci: np.ndarray         # contact index
    ti: np.ndarray         # time index
    is_simple: np.ndarray  # a Lambda_FI row (else Lambda_FIsuv)
    kind: np.ndarray       # KIND code
    is_pinch: np.ndarray
    is_multi: np.ndarray


def _velocity_source(run_ds: xr.Dataset) -> tuple[str, str]:
    """Name of the normal-velocity variable the impacts read, and the sentence that says so."""
    if "vn_free" in run_ds:
        return "vn_free", "vn_free: normal velocity before the jump of the impact step"
    if "vn_pre" in run_ds:
        return "vn_pre", ("vn_pre: the run file has no vn_free; start-of-step velocity used "
                          "instead (converges more slowly with dt)")
    raise ValueError("run dataset has neither 'vn_free' nor 'vn_pre'")


def _read_series(run_ds: xr.Dataset, vname: str) -> _Series:
    lam = np.asarray(run_ds["Lambda_N"].transpose("contact", "time").values, dtype=float)
    vn = np.asarray(run_ds[vname].transpose("contact", "time").values, dtype=float)
    nc, nt = lam.shape
    balls = (np.asarray(run_ds["ball"].values).astype(np.int64) if "ball" in run_ds.coords
             else np.arange(nc, dtype=np.int64))
    races = race_codes(run_ds, nc)
    step_ok = (np.asarray(run_ds["converged"].values).astype(bool) if "converged" in run_ds
               else np.ones(nt, bool))
    return _Series(lam=lam, vn=vn, times=np.asarray(run_ds["time"].values, dtype=float),
                   step_ok=step_ok, contacts=np.asarray(run_ds["contact"].values), balls=balls,
                   races=races, partner=_partners(balls, races))


def _filter(lam: np.ndarray, zero_tol: float, zero_floor: float) -> _Filtered:
    scale = max(float(np.max(lam)), 0.0) if lam.size else 0.0
    thr = zero_threshold(scale=scale, zero_tol=zero_tol, floor=zero_floor)
    fi, s, fisuv = split_impulses(lam, zero_tol, zero_floor, scale=scale)
    return _Filtered(fi=fi, s=s, fisuv=fisuv, threshold=thr, scale=scale, loaded=lam > thr)


def _classify(series: _Series, filt: _Filtered, e_N: float, m_ball: float) -> _Rows:
    """The impact rows (sorted by time, then contact) and their kinds from the data."""
    simple, persistent = impact_masks(filt.fi, filt.fisuv, filt.threshold)
    ci_s, ti_s = np.nonzero(simple)
    ci_p, ti_p = np.nonzero(persistent)
    ci = np.concatenate([ci_s, ci_p]).astype(np.int64)
    ti = np.concatenate([ti_s, ti_p]).astype(np.int64)
    is_simple = np.concatenate([np.ones(ci_s.size, bool), np.zeros(ci_p.size, bool)])
    order = np.lexsort((ci, ti))
    ci, ti, is_simple = ci[order], ti[order], is_simple[order]
    lam, vn, loaded = series.lam, series.vn, filt.loaded
    nt = lam.shape[1]
    ball_ids, ball_of_contact = np.unique(series.balls, return_inverse=True)
    ball_loaded = np.zeros((ball_ids.size, nt), dtype=bool)  # a contact of the ball is loaded
    np.logical_or.at(ball_loaded, ball_of_contact.ravel(), loaded)
    balls_loaded = ball_loaded.sum(axis=0)
    kind = np.where(is_simple, KIND["simple"], KIND["persistent"]).astype(np.int8)
    pc = series.partner[ci]
    # a pinch: the other contact of the ball is loaded within one step, and the impulse is more
    # than the ball alone could carry, (1 + e_N) m_ball |vn| at the contact's own speed, twice
    # over (so that a light ball rattling between two closing races, which alternates small
    # impulses between its contacts step after step, stays a single-ball impact)
    ball_bound = _BALL_FACTOR * (1.0 + e_N) * m_ball * np.abs(vn[ci, ti])
    pcs = np.maximum(pc, 0)  # (rows without a partner are masked out below)
    before, after = ti - 1, ti + 1
    partner_near = (loaded[pcs, ti]
                    | ((before >= 0) & loaded[pcs, np.maximum(before, 0)])
                    | ((after < nt) & loaded[pcs, np.minimum(after, nt - 1)]))
    is_pinch = (pc >= 0) & (lam[ci, ti] > ball_bound) & partner_near
    is_multi = ~is_pinch & (balls_loaded[ti] >= 2)
    kind[is_multi] = KIND["multi"]
    kind[is_pinch] = KIND["pinch"]
    return _Rows(ci=ci, ti=ti, is_simple=is_simple, kind=kind, is_pinch=is_pinch,
                 is_multi=is_multi)


def _impact_loads(series: _Series, filt: _Filtered, rows: _Rows, h: float):
    """Impulse, static force [N] and approach speed [m/s] of every row (pinches: the races
    through the ball)."""
    ci, ti, is_simple = rows.ci, rows.ti, rows.is_simple
    lam, vn, loaded = series.lam, series.vn, filt.loaded
    nt = lam.shape[1]
    impulse = np.where(is_simple, filt.fi[ci, ti], filt.fisuv[ci, ti])
    F_static = np.where(is_simple, 0.0, filt.s[ci, ti] / h)
    v_pre = -vn[ci, ti]
    pj = np.flatnonzero(rows.is_pinch)
    if not pj.size:
        return impulse, F_static, v_pre
    # a pinched ball transmits a static force only where both of its contacts carry it: the
    # static force is the part common to the two contacts in the neighbouring steps (a rattle
    # loads them in turn, never together), and the pinch impulse is what exceeds it
    c, p, k = ci[pj], series.partner[ci][pj], ti[pj]
    total = np.zeros(pj.size)
    count = np.zeros(pj.size)
    for i, valid in ((k - 1, k - 1 >= 0), (k + 1, k + 1 < nt)):
        i = np.clip(i, 0, nt - 1)
        total += np.where(valid, np.minimum(lam[c, i], lam[p, i]), 0.0)
        count += valid
    with np.errstate(invalid="ignore", divide="ignore"):
        fs_h = np.where(count > 0, np.maximum(total / np.maximum(count, 1), 0.0), 0.0)
    F_static[pj] = fs_h / h
    impulse[pj] = lam[c, k] - fs_h
    # a pinch approaches at the races' relative speed along the ball, taken in the step of the
    # row if the other contact is loaded in it too, else in the earlier step of the pair (the
    # later one already sees the races separating)
    earlier = (k > 0) & loaded[p, np.maximum(k - 1, 0)]
    k0 = np.where(loaded[p, k] | ~earlier, k, k - 1)
    v_pre[pj] = -(vn[c, k0] + vn[p, k0])
    return impulse, F_static, v_pre


def _flores(impulse, v_pre, F_static, K, e_N: float, h: float, v_min: float,
            contact_long_ratio: float, step_ok) -> dict:
    """Flores peak forces of the rows that have one, and the flags of every row."""
    n = impulse.size
    approach = np.isfinite(v_pre) & (v_pre > v_min)
    has_impulse = impulse > 0.0  # (a pinch row whose whole impulse is static force: no impact)
    flores = e_N > 0.0
    flags = np.zeros(n, dtype=np.int32)
    flags[~approach] |= FLAG["no_approach"]
    if not flores:
        flags |= FLAG["e_N_zero"]
    flags[~step_ok] |= FLAG["solver_unconverged"]
    out = {name: np.full(n, np.nan) for name in ("m_eff", "F_max", "contact_time", "v_rebound")}
    rows = np.flatnonzero(approach & flores & has_impulse)
    if rows.size:  # every impact's Flores force in one compiled loop (analysis.forces)
        res = peak_forces(impulse[rows], v_pre[rows], e_N, K[rows],
                          F_static=np.maximum(F_static[rows], 0.0), h=h)
        for name in out:
            out[name][rows] = res[name]
        # On a loaded contact the Flores damping acts on the whole static indentation: the
        # force starts at F_s (1 + 8 (1 - e_N) / (5 e_N)) whatever the impulse, and where the
        # impact adds less than that jump the peak is the start, a number the impact does not set
        onset = (res["t_peak"] == 0.0) & (F_static[rows] > 0.0)
        flags[rows[onset]] |= FLAG["peak_at_onset"]
    steps = out["contact_time"] / h
    # an impact that never ends (on a heavily preloaded contact, see analysis.forces) is long too
    long_ = np.isfinite(out["F_max"]) & ~(steps <= contact_long_ratio)
    flags[long_] |= FLAG["contact_long"]
    out.update(approach=approach, flags=flags, contact_time_steps=steps,
               trusted=(flags == 0) & np.isfinite(out["F_max"]))
    return out


def race_stresses(geo: dict, race: np.ndarray, force: np.ndarray) -> dict:
    """Hertz contact of every row at its force: ``{name: array}`` of ``contact_radius``,
    ``contact_semi_minor``, ``delta_max`` [m] and ``p_max`` [Pa] (NaN where there is none).

    Parameters
    ----------
    geo : dict
        The run's geometry (:func:`run_geometry`); its ``stress`` gives each race's contact.
    race : numpy.ndarray
        Race code of each row (:data:`RACE`).
    force : numpy.ndarray
        Normal force of each row [N] (NaN: no force).
    """
    out = {name: np.full(force.size, np.nan)
           for name in ("contact_radius", "contact_semi_minor", "delta_max", "p_max")}
    for code in (RACE["inner"], RACE["outer"]):
        sel = race == code
        if sel.any():
            for name, value in zip(out, geo["stress"](force[sel], code), strict=True):
                out[name][sel] = value
    return out


def _impact_dataset(data: dict, contact_long_ratio: float, vname: str) -> xr.Dataset:
    """The columns as a CF table (dimension ``impact``) with their categories' flag
    attributes."""
    n = data["time"].size
    ds = xr.Dataset(coords={"impact": ("impact", np.arange(n, dtype=np.int64),
                                       {"units": "1", "long_name": "impact number"})})
    for name, values in data.items():
        ds[name] = ("impact", values, _set_attrs(name, _VARS[name]))
    ds["race"].attrs.update(flag_values=np.array(list(RACE.values()), dtype=np.int8),
                            flag_meanings=" ".join(RACE))
    ds["kind"].attrs.update(flag_values=np.array(list(KIND.values()), dtype=np.int8),
                            flag_meanings=" ".join(KIND),
                            comment="pinch: both contacts of the ball loaded within one step; "
                                    "multi: several balls loaded in the step; persistent: on "
                                    "top of persistent contact; simple: isolated")
    ds["flags"].attrs.update(flag_masks=np.array(list(FLAG.values()), dtype=np.int32),
                             flag_meanings=" ".join(FLAG),
                             comment=f"contact_long: contact_time > {contact_long_ratio:g} dt; "
                                     "method_disagrees: a compliant zoom's F_max_zoom differs "
                                     "from F_max by more than analysis.method_tol; "
                                     "peak_at_onset: on a loaded contact the largest force is "
                                     "the start's F_static (1 + 8 (1 - e_N) / (5 e_N)), set by "
                                     "the static force, not by the impulse")
    ds["trusted"].attrs.update(flag_values=np.array([0, 1], dtype=np.int8),
                               flag_meanings="untrusted trusted")
    ds["approach"].attrs.pop("units", None)
    ds["approach"].attrs.update(flag_values=np.array([0, 1], dtype=np.int8),
                                flag_meanings="no_approach approach")
    ds["v_pre"].attrs["comment"] = f"from {vname}"
    return ds


def _with_parameters(ds: xr.Dataset, run_ds: xr.Dataset) -> xr.Dataset:
    """The run's study parameters as scalar coordinates with units."""
    for name in STUDY_PARAMETERS:
        units, long_name = _PARAM_ATTRS[name]
        try:
            value = _model_value(run_ds, name)
        except ValueError:
            continue
        ds = ds.assign_coords({name: ((), value, {"units": units, "long_name": long_name})})
    return ds


# (95 lines, 55 of them the docstring: the body is the named stages above, called in order)
def extract_impacts(run_ds: xr.Dataset, zero_tol=1e-4, zero_floor=1e-12, r_eff="concave",
                    v_min=1e-3, groove_conformity=None, contact_long_ratio=10.0) -> xr.Dataset:
    """Table of the impacts of one run with their kind, peak force, stresses and flags.

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run file's dataset: ``Lambda_N`` and ``vn_free`` (else ``vn_pre``) (time,
        contact), coordinates ``ball`` and ``race`` on ``contact``, model settings in attrs (see
        :func:`run_geometry`), ``solver.dt`` (else the median time step) and e_N (scalar
        coordinate or ``model.e_N``); ``converged`` (time) if present.
    zero_tol : float
        Relative zero threshold of the filter [-]; the scale is the run's largest Λ_N.
    zero_floor : float
        Absolute floor of the zero threshold [N s].
    r_eff : {"concave", "paper"}
        Effective radius of the outer-race contacts (:func:`run_geometry`).
    v_min : float
        Smallest approach speed for a Flores force [m/s]. Impacts with v_pre <= v_min stay in the
        table flagged ``no_approach``, F_max and what follows from it missing (NaN).
    groove_conformity : float or None
        Race groove radius over ball diameter (e.g. 0.52, > 0.5) for elliptical Hertz
        contacts; None or 0 (default): the run's own contacts (:func:`run_geometry`).
    contact_long_ratio : float
        An impact whose Hertz contact time exceeds this many time steps is flagged
        ``contact_long`` (the rigid solver resolves it over several steps while the mechanism
        keeps loading it).

    Returns
    -------
    xarray.Dataset
        CF-1.10 table, dimension ``impact`` (sorted by time, then contact); the columns are
        described by their ``long_name`` (and ``docs/forces.md``); ``kind``, ``race`` and
        ``flags`` are small integers with ``flag_values``/``flag_masks`` and
        ``flag_meanings``; ``K`` is stored squared (UDUNITS has no fractional powers). The
        swept parameters are scalar coordinates with units. Attributes: the settings, the zero
        threshold [N s], the stiffnesses [N m-1.5], ``v_pre_source`` and counts ``n_simple``,
        ``n_persistent`` (filter classes), ``n_pinch``, ``n_multi``, ``n_no_approach``,
        ``n_flagged``, ``n_trusted``.

    Notes
    -----
    The stages: read the run's series (:func:`_read_series`), split every contact's impulses
    (:func:`_filter`), find the rows and their kinds (:func:`_classify`), their impulse, static
    force and approach speed (:func:`_impact_loads`), the Flores forces and flags
    (:func:`_flores`), the Hertz stresses at the peak (:func:`race_stresses`), and the table
    (:func:`_impact_dataset`).
    """
    if "Lambda_N" not in run_ds:
        raise ValueError("run dataset has no variable 'Lambda_N'")
    vname, source = _velocity_source(run_ds)
    v_min = positive("v_min", v_min)
    contact_long_ratio = positive("contact_long_ratio", contact_long_ratio)
    if groove_conformity is not None:
        groove_conformity = positive("groove_conformity", groove_conformity) \
            if groove_conformity != 0 else None  # 0: off, as in the config
    geo = run_geometry(run_ds, r_eff, groove_conformity)
    e_N = _model_value(run_ds, "e_N")
    h = _time_step(run_ds)

    series = _read_series(run_ds, vname)
    filt = _filter(series.lam, zero_tol, zero_floor)
    rows = _classify(series, filt, e_N, _model_value(run_ds, "ball_mass"))
    impulse, F_static, v_pre = _impact_loads(series, filt, rows, h)
    race = series.races[rows.ci]
    K = np.where(race == RACE["outer"], geo["K_outer"], geo["K_inner"]).astype(float)
    K[rows.is_pinch] = geo["K_pinch"]
    forces = _flores(impulse, v_pre, F_static, K, e_N, h, v_min, contact_long_ratio,
                     series.step_ok[rows.ti])
    data = {
        "contact": series.contacts[rows.ci].astype(np.int64),
        "ball": series.balls[rows.ci].astype(np.int64),
        "race": race.astype(np.int8),
        "time": series.times[rows.ti],
        "kind": rows.kind,
        "impulse": impulse,
        "v_pre": v_pre,
        "approach": forces["approach"].astype(np.int8),
        "m_eff": forces["m_eff"],
        "F_static": F_static,
        "K": K**2,
        "F_max": forces["F_max"],
        **race_stresses(geo, race, forces["F_max"]),
        "contact_time": forces["contact_time"],
        "contact_time_steps": forces["contact_time_steps"],
        "v_rebound": forces["v_rebound"],
        "flags": forces["flags"],
        "trusted": forces["trusted"].astype(np.int8),
    }
    ds = _with_parameters(_impact_dataset(data, contact_long_ratio, vname), run_ds)
    settings = {"zero_tol": float(zero_tol), "zero_floor": float(zero_floor), "r_eff": r_eff,
                "groove_conformity": groove_conformity,
                "contact_long_ratio": float(contact_long_ratio), "v_min": v_min}
    ds.attrs.update(_table_attrs(run_ds, settings, filt, rows, forces, geo, source, e_N, h))
    return count_flags(ds)


def _table_attrs(run_ds, settings, filt, rows, forces, geo, source, e_N, h) -> dict:
    """The impact table's global attributes: provenance, settings, threshold, stiffnesses and
    counts."""
    from simcore import __version__

    groove = settings["groove_conformity"]
    history = ", ".join(f"{key}={value:g}" if isinstance(value, float) else f"{key}={value}"
                        for key, value in dict(settings, groove_conformity="none"
                                               if groove is None else float(groove)).items())
    attrs = {
        "Conventions": "CF-1.10",
        "title": "impacts of one run: kind, Flores peak force, Hertz stresses, trust flags",
        "source": f"bearingsim {__version__} (analysis.extract_impacts)",
        "history": f"analysis.extract_impacts({history}) on run "
                   f"'{run_ds.attrs.get('title', 'untitled')}'",
        **settings,
        "groove_conformity": "none" if groove is None else float(groove),
        "zero_threshold": float(filt.threshold),
        "zero_threshold_units": "N s",
        "lambda_scale": filt.scale,
        "v_pre_source": source,
        "e_N": e_N,
        "h": h,
        **{key: geo[key] for key in ("E", "nu", "ball_radius", "inner_radius", "outer_radius",
                                     "K_inner", "K_outer", "K_pinch")},
        "stiffness_units": "N m-1.5",
        "contact_geometry": geo["contacts"],
        "n_simple": int(rows.is_simple.sum()),
        "n_persistent": int((~rows.is_simple).sum()),
        "n_pinch": int(rows.is_pinch.sum()),
        "n_multi": int(rows.is_multi.sum()),
        "n_no_approach": int((~forces["approach"]).sum()),
        "dt_check": 0,
    }
    if "title" in run_ds.attrs:
        attrs["run_title"] = str(run_ds.attrs["title"])
    return attrs


def count_flags(impacts_ds: xr.Dataset) -> xr.Dataset:
    """Set the table's attributes ``n_flagged`` and ``n_trusted`` from its columns ``flags``
    and ``trusted`` (in place; returns the table)."""
    impacts_ds.attrs["n_flagged"] = int(np.count_nonzero(impacts_ds["flags"].values))
    impacts_ds.attrs["n_trusted"] = int(np.count_nonzero(impacts_ds["trusted"].values))
    return impacts_ds


def race_name(code) -> str:
    """'inner' or 'outer' for a race code (0 or 1)."""
    return {v: k for k, v in RACE.items()}[int(code)]


def kind_name(code) -> str:
    """The kind name of a kind code."""
    return {v: k for k, v in KIND.items()}[int(code)]


def flag_names(mask) -> str:
    """The names of the bits set in a ``flags`` value (:data:`FLAG`), joined by '+'; '' for
    none."""
    return "+".join(name for name, bit in FLAG.items() if int(mask) & bit)


def top_forces(impacts_ds: xr.Dataset, n=3, race="outer", events=None) -> xr.Dataset:
    """The ``n`` largest peak forces of an impact table.

    Parameters
    ----------
    impacts_ds : xarray.Dataset
        Output of :func:`extract_impacts`.
    n : int
        How many.
    race : {"outer", "inner", None}
        Restrict to one race (None: all contacts).
    events : numpy.ndarray, optional
        An event number per row (:func:`loaded_stretches`): rows with one number give only
        their largest force, so that a persistent contact, which the filter can give many
        rows, counts once. None: every row counts.

    Returns
    -------
    xarray.Dataset
        The selected rows, largest F_max first (impacts without a force are skipped).
    """
    ds = impacts_ds
    force = ds["F_max"].values
    mask = np.isfinite(force)
    if race is not None:
        mask &= ds["race"].values == RACE[race]
    return ds.isel(impact=largest_first(force, np.flatnonzero(mask), events)[:n])


def largest_first(force, rows, events=None) -> np.ndarray:
    """The indices ``rows`` ordered by ``force`` [N], largest first; with ``events`` (a number
    per row of ``force``, :func:`loaded_stretches`), only the largest row of each event."""
    rows = rows[np.argsort(-force[rows], kind="stable")]
    if events is not None:  # (sorted by force: the first row of each event is its largest)
        rows = rows[np.unique(np.asarray(events)[rows], return_index=True)[1]]
        rows = rows[np.argsort(-force[rows], kind="stable")]
    return rows


def loaded_stretches(run_ds: xr.Dataset, impacts_ds: xr.Dataset) -> np.ndarray:
    """The event number of each row of ``impacts_ds`` (the impact table of ``run_ds``): the
    stretch of consecutive steps in which its contact's impulse ``Lambda_N`` stays above the
    table's zero threshold (one impact, or one persistent contact, to which the filter gives a
    row wherever the impulse varies). A row outside any stretch is an event of its own."""
    lam = run_ds["Lambda_N"].transpose("contact", "time").values
    loaded = lam > impacts_ds.attrs["zero_threshold"]
    before = np.zeros_like(loaded)
    before[:, 1:] = loaded[:, :-1]
    number = np.cumsum((loaded & ~before).ravel()).reshape(loaded.shape)
    time = run_ds["time"].values
    t = impacts_ds["time"].values
    k = np.clip(np.searchsorted(time, t), 1, time.size - 1)
    k -= np.abs(time[k - 1] - t) < np.abs(time[k] - t)  # (the nearest step)
    c = impacts_ds["contact"].values
    return np.where(loaded[c, k], number[c, k], -1 - np.arange(c.size))


def stiffness(impacts_ds: xr.Dataset) -> np.ndarray:
    """K [N m-1.5] of every row (the table stores K squared)."""
    return np.sqrt(np.asarray(impacts_ds["K"].values, dtype=float))



