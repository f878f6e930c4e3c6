"""Figures of one run and of the study (matplotlib, Agg backend).

* :func:`plot_run`: the Λ history of the most loaded contact with its three filtered parts and two
  zooms (an isolated impact, an impact on persistent contact) - the paper's Figs 2b, 4, 6, 7; the
  journal orbit with the clearance circle; the slider position against the ideal slider-crank.
* :func:`plot_study`: peak force and impact counts against each swept parameter, one line per
  value of a second swept parameter.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from simcore.config import schema_default  # noqa: E402
from simcore.model.driver import CONTACT_MODELS  # noqa: E402
from simcore.study.plan import (  # noqa: E402
    FIGURE_KEYS,
    FigureSettingNames,
    check_figure_settings,
)

from .filtering import impact_masks, split_impulses, zero_threshold  # noqa: E402
from .impacts import STUDY_PARAMETERS  # noqa: E402
from .reads import run_setting  # noqa: E402

__all__ = ["plot_run", "plot_reference", "plot_study", "plot_life", "run_label", "run_prefix",
           "figure_layout",
           "FigureLayout", "grid_axes", "MAX_PANELS", "MAX_CELLS"]

RACE_NAMES = ("inner", "outer")

_PARAM = {
    # name: (label, unit shown, factor from SI)
    "clearance": ("clearance g", "µm", 1e6),
    "mu": ("friction μ", "–", 1.0),
    "omega0": ("crank speed ω0", "rad/s", 1.0),
    "e_N": ("restitution e_N", "–", 1.0),
}


#: The bearing a run title does not name: the default, the paper's as modelled.
PAPER_BEARING = str(schema_default("model", "bearing"))


def _param_value(ds, name):
    value = run_setting(ds, name, None)
    return None if value is None else float(value)


def _run_parameters(ds):
    """``(name, value)`` of each study parameter the run states, in study order."""
    for name in STUDY_PARAMETERS:
        value = _param_value(ds, name)
        if value is not None:
            yield name, value


def _fmt_param(name, value):
    label, unit, fac = _PARAM.get(name, (name, "", 1.0))
    short = label.split()[-1]
    unit_txt = "" if unit in ("", "–") else f" {unit}"
    return f"{short} = {value * fac:.4g}{unit_txt}"


def run_label(ds) -> str:
    """Human-readable parameters of a run, e.g. ``g = 400 µm, μ = 0.01, ω0 = 50 rad/s, e_N = 0.9``
    (a catalogue bearing other than the paper's named first: ``6205 in C3, g = 10.25 µm, ...``).

    Parameters
    ----------
    ds : xarray.Dataset
        A run or impact dataset with the study parameters as scalar coords or ``model.*`` attrs.

    Returns
    -------
    str
    """
    parts = [_fmt_param(name, v) for name, v in _run_parameters(ds)]
    bearing = run_setting(ds, "bearing", None)
    if bearing is not None and str(bearing) != PAPER_BEARING:  # a catalogue bearing: name it
        clearance_class = run_setting(ds, "clearance_class", None)
        parts.insert(0, str(bearing) + (f" in {clearance_class}" if clearance_class else ""))
    return ", ".join(parts) if parts else "run"


def run_prefix(ds) -> str:
    """File-name prefix from the run's parameters, e.g. ``clearance0.0004_mu0.01_omega050_e_N0.9``.

    Parameters
    ----------
    ds : xarray.Dataset
        A run dataset.

    Returns
    -------
    str
    """
    parts = [f"{name}{v:g}" for name, v in _run_parameters(ds)]
    return "_".join(parts) if parts else "run"


def _contact_label(ds, c):
    ball = int(ds["ball"].values[c]) if "ball" in ds.coords else None
    race = str(ds["race"].values[c]) if "race" in ds.coords else None
    txt = f"contact {int(ds['contact'].values[c])}"
    if ball is not None and race is not None:
        txt += f" (ball {ball} – {race} race)"
    return txt


def _fmt_force(f):
    return f"{f / 1e3:.3g} kN" if abs(f) >= 1e3 else f"{f:.3g} N"


def _pick_zoom(mask, weight):
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return None
    return int(idx[np.argmax(weight[idx])])


def _lookup_force(impacts_ds, contact, time):
    if impacts_ds is None or impacts_ds.sizes.get("impact", 0) == 0:
        return None
    sel = (impacts_ds["contact"].values == contact) & np.isclose(
        impacts_ds["time"].values, time, rtol=0, atol=1e-12 + 1e-9 * abs(time))
    idx = np.flatnonzero(sel)
    if idx.size == 0:
        return None
    return float(impacts_ds["F_max"].values[idx[0]])


def _plot_lambda(run_ds, impacts_ds, path, zero_tol, zero_floor, contact=None):
    lam_all = np.asarray(run_ds["Lambda_N"].transpose("contact", "time").values, dtype=float)
    scale = max(float(np.max(lam_all)), 0.0) if lam_all.size else 0.0
    thr = zero_threshold(scale=scale, zero_tol=zero_tol, floor=zero_floor)
    if contact is None:
        c = int(np.argmax(lam_all.sum(axis=1))) if lam_all.size else 0
    else:
        c = int(np.flatnonzero(run_ds["contact"].values == contact)[0])
    lam = lam_all[c]
    fi, s, fisuv = split_impulses(lam, zero_tol, zero_floor, scale=scale)
    simple, persistent = impact_masks(fi, fisuv, thr)
    t = np.asarray(run_ds["time"].values, dtype=float)
    tm = t * 1e3

    fig = plt.figure(figsize=(14, 9.5), layout="constrained")
    gs = fig.add_gridspec(4, 2, width_ratios=(2.2, 1))
    axes = [fig.add_subplot(gs[0, 0])]
    for r in range(1, 4):
        axes.append(fig.add_subplot(gs[r, 0], sharex=axes[0]))
    za = fig.add_subplot(gs[0:2, 1])
    zb = fig.add_subplot(gs[2:4, 1])
    series = [
        (lam, "Λ (discrete normal impulse)", "k"),
        (fi, "Λ_FI (simple impacts)", "tab:red"),
        (s, "Λ_S (smooth part = persistent force × h)", "tab:blue"),
        (fisuv, "Λ_FIsuv (impacts on persistent contact)", "tab:orange"),
    ]
    for ax, (y, name, col) in zip(axes, series, strict=True):
        if y is fi or y is fisuv:
            ax.vlines(tm, 0, y, color=col, lw=1.0)
            mk = simple if y is fi else persistent
            ax.plot(tm[mk], y[mk], "o", ms=3, color=col,
                    label=f"{name}: {int(mk.sum())} above threshold")
            ax.axhline(thr, color="0.5", ls="--", lw=0.8, label=f"zero threshold {thr:.3g} N s")
        else:
            ax.plot(tm, y, "-", color=col, lw=0.8, label=name)
        ax.set_ylabel("impulse [N s]")
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel("time [ms]")

    half = 12
    for ax, mask, weight, what in (
        (za, simple, fi, "isolated impact (Detail A)"),
        (zb, persistent, fisuv, "impact on persistent contact (Detail B)"),
    ):
        k = _pick_zoom(mask, weight)
        if k is None:
            ax.text(0.5, 0.5, f"no {what}\nabove the threshold on this contact",
                    ha="center", va="center", transform=ax.transAxes)
            ax.set_axis_off()
            continue
        sl = slice(max(k - half, 0), min(k + half + 1, lam.size))
        ax.plot(tm[sl], lam[sl], "ko-", ms=4, lw=1, label="Λ")
        ax.plot(tm[sl], s[sl], "s--", color="tab:blue", ms=3, lw=1, label="Λ_S")
        ax.vlines(tm[sl], 0, fi[sl], color="tab:red", lw=3, label="Λ_FI")
        ax.vlines(tm[sl], s[sl], s[sl] + fisuv[sl], color="tab:orange", lw=3,
                  label="Λ_FIsuv (on top of Λ_S)")
        fmax = _lookup_force(impacts_ds, int(run_ds["contact"].values[c]), t[k])
        ftxt = ("F_max: no approach (v_pre ≤ v_min)" if fmax is not None and math.isnan(fmax)
                else f"F_max = {_fmt_force(fmax)}" if fmax is not None else "")
        ax.set_title(f"Zoom: {what}\nt = {t[k] * 1e3:.2f} ms, impulse = {weight[k]:.3g} N s"
                     + (f"\n{ftxt}" if ftxt else ""), fontsize=9)
        ax.set_xlabel("time [ms]")
        ax.set_ylabel("impulse [N s]")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle(f"Impulse history and filter — {_contact_label(run_ds, c)}\n{run_label(run_ds)}"
                 f"  (zero_tol = {zero_tol:g}, floor = {zero_floor:g} N s)")
    return _save(fig, path)


def _clearance(ds):
    v = _param_value(ds, "clearance")
    return v


def _plot_orbit(run_ds, path):
    if "journal_x" not in run_ds or "journal_y" not in run_ds:
        warnings.warn("run has no journal_x/journal_y: orbit figure skipped", stacklevel=3)
        return None
    x = np.asarray(run_ds["journal_x"].values, dtype=float) * 1e6
    y = np.asarray(run_ds["journal_y"].values, dtype=float) * 1e6
    t = np.asarray(run_ds["time"].values, dtype=float)
    fig, ax = plt.subplots(figsize=(7, 6.5), layout="constrained")
    ax.plot(x, y, "-", color="0.6", lw=0.5)
    sc = ax.scatter(x, y, c=t * 1e3, s=3, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="time [ms]")
    g = _clearance(run_ds)
    if g is not None:
        th = np.linspace(0, 2 * np.pi, 361)
        ax.plot(g * 1e6 * np.cos(th), g * 1e6 * np.sin(th), "r--", lw=1,
                label=f"clearance circle, g = {g * 1e6:.4g} µm")
        ax.legend(loc="upper right", fontsize=8)
    ax.plot([0], [0], "k+", ms=10)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x, outer race centre − inner race centre [µm]")
    ax.set_ylabel("y, outer race centre − inner race centre [µm]")
    ax.grid(alpha=0.3)
    ax.set_title(f"Journal orbit (rod big end relative to crank pin)\n{run_label(run_ds)}")
    return _save(fig, path)


def _plot_slider(run_ds, path):
    needed = ("slider_x", "crank_angle")
    if any(n not in run_ds for n in needed):
        warnings.warn("run has no slider_x/crank_angle: slider figure skipped", stacklevel=3)
        return None
    L1, L2 = (run_setting(run_ds, key, None) for key in ("crank_length", "rod_length"))
    if L1 is None or L2 is None:
        warnings.warn("run lacks model.crank_length/rod_length: slider figure skipped",
                      stacklevel=3)
        return None
    L1, L2 = float(L1), float(L2)
    t = np.asarray(run_ds["time"].values, dtype=float)
    th = np.asarray(run_ds["crank_angle"].values, dtype=float)
    x = np.asarray(run_ds["slider_x"].values, dtype=float)
    ideal = L1 * np.cos(th) + np.sqrt(L2**2 - (L1 * np.sin(th)) ** 2)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 7), sharex=True, layout="constrained")
    a1.plot(t * 1e3, x * 1e3, "k-", lw=1.2, label="simulated (bearing with clearance)")
    a1.plot(t * 1e3, ideal * 1e3, "r--", lw=1, label="ideal slider-crank (no clearance)")
    a1.set_ylabel("slider position x [mm]")
    a1.legend(fontsize=8)
    a1.grid(alpha=0.3)
    a2.plot(t * 1e3, (x - ideal) * 1e6, "b-", lw=0.8)
    g = _clearance(run_ds)
    if g is not None:
        for sgn in (-1, 1):
            a2.axhline(sgn * g * 1e6, color="r", ls=":", lw=0.8)
        a2.text(0.01, 0.95, f"dotted: ± clearance g = {g * 1e6:.4g} µm", transform=a2.transAxes,
                va="top", fontsize=8)
    a2.set_ylabel("x − x_ideal [µm]")
    a2.set_xlabel("time [ms]")
    a2.grid(alpha=0.3)
    a1.set_title(f"Slider position against the ideal slider-crank "
                 f"(L1 = {L1:g} m, L2 = {L2:g} m)\n{run_label(run_ds)}")
    return _save(fig, path)


def plot_run(run_ds: xr.Dataset, impacts_ds: xr.Dataset | None, outdir, zero_tol=1e-4,
             zero_floor=1e-12, prefix=None, contact=None) -> list[Path]:
    """Figures of one run.

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run file's dataset.
    impacts_ds : xarray.Dataset or None
        Its impact table (:func:`analysis.extract_impacts`), used to print F_max in the zooms.
    outdir : str or Path
        Output folder (created).
    zero_tol, zero_floor : float
        Filter threshold settings [-], [N s] (as for the impact table).
    prefix : str, optional
        File-name prefix; default from the run's parameters (:func:`run_prefix`).
    contact : int, optional
        Contact to show; default the most loaded one (largest total Λ_N).

    Returns
    -------
    list of Path
        ``<prefix>_lambda.png``, and ``<prefix>_orbit.png`` (only when the run has
        ``journal_x``/``journal_y``) and ``<prefix>_slider.png`` (when slider data and rod
        lengths are present).
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    prefix = prefix or run_prefix(run_ds)
    out = [_plot_lambda(run_ds, impacts_ds, outdir / f"{prefix}_lambda.png", zero_tol,
                        zero_floor, contact)]
    for fn, suffix in ((_plot_orbit, "orbit"), (_plot_slider, "slider")):
        p = fn(run_ds, outdir / f"{prefix}_{suffix}.png")
        if p is not None:
            out.append(p)
    return [Path(p) for p in out]


# --- reference run: steady operation ------------------------------------------------------

_RACE_COLOURS = {0: "tab:blue", 1: "tab:red"}
_KIND_MARKERS = {0: "o", 1: "x", 2: "s", 3: "^"}


def _impact_columns(impacts_ds, run_ds, settle):
    """Impact table as plain arrays with race/kind codes, crank angle and steady mask."""
    from .summary import KINDS, RACES, category_codes, steady_window

    n = 0 if impacts_ds is None else impacts_ds.sizes.get("impact", 0)

    def col(name, fill=np.nan):
        if n and name in impacts_ds:
            return np.asarray(impacts_ds[name].values)
        return np.full(n, fill)

    def codes(name, names):
        if n and name in impacts_ds:
            return category_codes(impacts_ds[name].values,
                                  impacts_ds[name].attrs.get("flag_meanings"), names)
        return np.full(n, -1)

    t = np.asarray(run_ds["time"].values, dtype=float)
    theta = np.asarray(run_ds["crank_angle"].values, dtype=float)
    t_settle, revs = steady_window(t, theta, settle)
    time = col("time").astype(float)
    out = {
        "time": time,
        "race": codes("race", RACES),
        "kind": codes("kind", KINDS),
        "F_max": col("F_max").astype(float),
        "v_pre": col("v_pre").astype(float),
        "ball": col("ball", -1).astype(float),
        "theta": np.interp(time, t, theta) if n else np.zeros(0),
        "steady": time > t_settle,
        "settle_time": t_settle,
        "revolutions": revs,
    }
    return out


def _steady_title(cols, settle):
    return (f"statistics over t > {cols['settle_time']:.3g} s (after {settle:g} start-up "
            f"revolution(s)): {cols['revolutions']:.3g} revolutions")


def _plot_force_angle(run_ds, cols, path, settle, zero_tol, zero_floor):
    """Persistent force per race (Λ_S/h summed over the balls) and impact peaks over the crank
    angle, every steady revolution overlaid."""
    lam = np.asarray(run_ds["Lambda_N"].transpose("contact", "time").values, dtype=float)
    h = float(run_ds.attrs.get("solver.dt", np.median(np.diff(run_ds["time"].values))))
    _, smooth, _ = split_impulses(lam, zero_tol, zero_floor)
    from .summary import RACES, category_codes

    race_of_contact = category_codes(run_ds["race"].values,
                                     run_ds["race"].attrs.get("flag_meanings"), RACES)
    t = np.asarray(run_ds["time"].values, dtype=float)
    theta = np.asarray(run_ds["crank_angle"].values, dtype=float)
    deg = np.degrees(np.mod(theta, 2 * np.pi))
    steady_t = t > cols["settle_time"]
    rev = np.floor((theta - theta[0]) / (2 * np.pi)).astype(int)
    fig, axes = plt.subplots(2, 1, figsize=(11, 8), sharex=True, layout="constrained")
    for r, ax in enumerate(axes):
        force = smooth[race_of_contact == r].sum(axis=0) / h
        for k in np.unique(rev[steady_t]):
            sel = steady_t & (rev == k)
            # break the line where the angle wraps from 360 to 0 degrees
            y = np.where(np.r_[False, np.diff(deg[sel]) < 0], np.nan, force[sel])
            ax.plot(deg[sel], y, "-", color="0.4", lw=0.7,
                    label="persistent force Λ_S/h, all balls (one line per revolution)"
                    if k == np.unique(rev[steady_t])[0] else None)
        m = cols["steady"] & (cols["race"] == r) & np.isfinite(cols["F_max"])
        ax.plot(np.degrees(np.mod(cols["theta"][m], 2 * np.pi)), cols["F_max"][m], ".",
                color=_RACE_COLOURS[r], ms=4, label=f"impact peak force F_max ({m.sum()})")
        ax.set_yscale("symlog", linthresh=10.0)
        ax.set_ylabel("force [N]")
        ax.set_title(f"{RACES[r]} race")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="lower center", framealpha=0.9)
    axes[-1].set_xlabel("crank angle [deg] (0 = crank along +x, slider at its far end)")
    axes[-1].set_xticks(np.arange(0, 361, 45))
    fig.suptitle("Contact force over the crank angle, reference run\n"
                 f"{run_label(run_ds)}; {_steady_title(cols, settle)}")
    return _save(fig, path)


def _ball_angles(run_ds, cols):
    """Angle of each impact's ball around its race, in the race's own body frame [rad]."""
    if "q" not in run_ds:  # a run file keeps position and angle apart
        from simcore.io import generalized

        run_ds = generalized(run_ds)
    q = np.asarray(run_ds["q"].transpose("time", "body", "dof").values, dtype=float)
    t = np.asarray(run_ds["time"].values, dtype=float)
    L1 = float(run_setting(run_ds, "crank_length"))
    theta = np.asarray(run_ds["crank_angle"].values, dtype=float)
    idx = np.clip(np.searchsorted(t, cols["time"]), 0, t.size - 1)
    balls = cols["ball"].astype(int)
    ok = (balls >= 0) & (balls + 3 < q.shape[1])
    pin = np.stack([L1 * np.cos(theta), L1 * np.sin(theta)], axis=1)
    outer = pin + np.stack([run_ds["journal_x"].values, run_ds["journal_y"].values], axis=1)
    angles = np.full(idx.size, np.nan)
    for k in np.flatnonzero(ok):
        i, b = idx[k], balls[k] + 3  # bodies: crank, rod, slider, ball0, ball1, ...
        if cols["race"][k] == 0:
            d, frame = q[i, b, :2] - pin[i], theta[i]
        else:
            d, frame = q[i, b, :2] - outer[i], q[i, 1, 2]
        angles[k] = np.arctan2(d[1], d[0]) - frame
    return np.mod(angles, 2 * np.pi)


def _plot_ball_load(run_ds, cols, path, settle):
    angles = _ball_angles(run_ds, cols)
    n_balls = int(run_setting(run_ds, "n_balls", np.nanmax(cols["ball"]) + 1))
    fig, axes = plt.subplots(1, 2, figsize=(13, 8.2), subplot_kw={"projection": "polar"},
                             layout="constrained")
    cmap = plt.get_cmap("tab10")
    for r, (ax, frame) in enumerate(zip(axes, ("crank frame: 0° points from the crank pivot "
                                                "through the pin", "rod frame: 0° points from "
                                                "the big end towards the slider"), strict=True)):
        for b in range(n_balls):
            m = (cols["steady"] & (cols["race"] == r) & (cols["ball"] == b)
                 & np.isfinite(cols["F_max"]) & np.isfinite(angles))
            peak = f", peak {_fmt_force(cols['F_max'][m].max())}" if m.any() else ""
            ax.scatter(angles[m], cols["F_max"][m] / 1e3, s=9, color=cmap(b % 10), alpha=0.7,
                       label=f"ball {b}: {m.sum()} impacts{peak}")
        ax.set_title(f"{('inner', 'outer')[r]} race, {frame}\nradius: peak force F_max [kN]",
                     fontsize=9)
        ax.set_rlabel_position(100)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=2)
    fig.suptitle("Where the impacts land: angle of the hit ball on each race (in the race's "
                 "own frame) and its peak force\n"
                 f"{run_label(run_ds)}; {_steady_title(cols, settle)}")
    return _save(fig, path)


def _save(fig, path, dpi=110):
    """Write ``fig`` to ``path`` at ``dpi`` dots per inch, close it, return ``path``."""
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _log_log(ax, xlabel, ylabel, legend_loc):
    """Log-log axes of the impact figures: labels, major and minor grid, legend."""
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc=legend_loc)


def _plot_exceedance(run_ds, cols, path, settle, force_levels):
    fig, ax = plt.subplots(figsize=(9, 6), layout="constrained")
    revs = cols["revolutions"]
    for r, name in enumerate(("inner", "outer")):
        f = np.sort(cols["F_max"][cols["steady"] & (cols["race"] == r)
                                  & np.isfinite(cols["F_max"])])[::-1]
        f = f[f > 0]
        if f.size and revs > 0:
            rate = np.arange(1, f.size + 1) / revs
            ax.step(f, rate, where="post", color=_RACE_COLOURS[r],
                    label=f"{name} race ({f.size} impacts with a force)")
        s = cols["F_max"][~cols["steady"] & (cols["race"] == r)]
        if np.isfinite(s).any():
            ax.axvline(np.nanmax(s), color=_RACE_COLOURS[r], ls="--", lw=0.8,
                       label=f"{name} race, start-up peak {_fmt_force(np.nanmax(s))}")
    for level in force_levels:
        ax.axvline(level, color="0.3", ls=":", lw=1)
        ax.text(level, 1.0, f" {_fmt_force(level)}", transform=ax.get_xaxis_transform(),
                va="top", fontsize=8)
    _log_log(ax, "force F [N]", "impacts per crank revolution with a peak force F_max ≥ F",
             "lower left")
    ax.set_title("Exceedance of the impact peak force, per race (dotted: analysis.force_levels)"
                 f"\n{run_label(run_ds)}\n{_steady_title(cols, settle)}", fontsize=10)
    return _save(fig, path)


def _plot_force_speed(run_ds, cols, path, settle):
    from .summary import KINDS

    fig, ax = plt.subplots(figsize=(9, 6.5), layout="constrained")
    ok = np.isfinite(cols["F_max"]) & (cols["v_pre"] > 0)
    m = ok & ~cols["steady"]
    ax.scatter(cols["v_pre"][m], cols["F_max"][m], s=10, color="0.7", marker="o",
               label=f"start-up ({m.sum()})")
    for r, name in enumerate(("inner", "outer")):
        for k, kind in enumerate(KINDS):
            m = ok & cols["steady"] & (cols["race"] == r) & (cols["kind"] == k)
            if m.any():
                ax.scatter(cols["v_pre"][m], cols["F_max"][m], s=12, color=_RACE_COLOURS[r],
                           marker=_KIND_MARKERS[k], alpha=0.7, linewidths=0.8,
                           label=f"{name} race, {kind} ({m.sum()})")
    _log_log(ax, "approach speed v_pre [m/s]", "peak force F_max [N]", "upper left")
    ax.set_title("Impact peak force against approach speed (Hertz: F_max ∝ m_eff^0.6 "
                 f"v_pre^1.2 at a given stiffness)\n{run_label(run_ds)}\n"
                 f"{_steady_title(cols, settle)}", fontsize=10)
    return _save(fig, path)


def _plot_iterations(run_ds, cols, path, settle):
    it = np.asarray(run_ds["iterations"].transpose("time", "stage").values, dtype=float)[1:]
    t = np.asarray(run_ds["time"].values, dtype=float)[1:]
    names = ("smooth", "position", "velocity")
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5.5), layout="constrained",
                                 gridspec_kw={"width_ratios": (2, 1)})
    for s in range(it.shape[1]):
        a1.plot(t * 1e3, it[:, s] + 0.12 * (s - 1), ".", ms=1.5, color=f"C{s}",
                label=f"{names[s]}: max {int(it[:, s].max())}, mean {it[:, s].mean():.2f}")
        counts = np.bincount(it[:, s].astype(int))
        used = np.flatnonzero(counts)
        a2.plot(used, counts[used], "o-", color=f"C{s}", ms=4, label=names[s])
    a1.axvspan(0, cols["settle_time"] * 1e3, color="0.9", label="start-up (not in statistics)")
    a1.set_xlabel("time [ms]")
    a1.set_ylabel("Newton iterations of the step (stages offset by ±0.12)")
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8, markerscale=6, loc="upper right")
    a2.set_yscale("log")
    a2.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    a2.set_xlabel("Newton iterations of the step")
    a2.set_ylabel("number of steps")
    a2.grid(alpha=0.3, which="both")
    a2.legend(fontsize=8)
    n_bad = int(np.sum(np.asarray(run_ds["converged"].values)[1:] == 0))
    fig.suptitle(f"Solver iterations per step and sub-problem ({t.size} steps, {n_bad} "
                 f"unconverged)\n{run_label(run_ds)}")
    return _save(fig, path)


def plot_reference(run_ds: xr.Dataset, impacts_ds: xr.Dataset | None, outdir, settle=0.0,
                   force_levels=(100.0, 1000.0), zero_tol=1e-4, zero_floor=1e-12,
                   prefix="reference") -> list[Path]:
    """Figures of one run in steady operation (the study's reference run).

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run, with ``crank_angle``, ``q``, ``journal_x``/``journal_y``, ``iterations``.
    impacts_ds : xarray.Dataset or None
        Its impact table (columns ``time``, ``race``, ``kind``, ``ball``, ``F_max``,
        ``v_pre``; string or integer categories).
    outdir : str or Path
        Output folder (created).
    settle : float
        Start-up left out [crank revolutions] (:func:`analysis.summary.steady_window`).
    force_levels : sequence of float
        Absolute force levels marked on the exceedance curve [N].
    zero_tol, zero_floor : float
        Filter settings for the persistent force (as for the impact table).
    prefix : str
        File-name prefix.

    Returns
    -------
    list of Path
        ``<prefix>_force_angle.png`` (persistent force and impact peaks over the crank angle),
        ``<prefix>_ball_load.png`` (polar: where the impacts land on each race),
        ``<prefix>_exceedance.png`` (impacts per revolution above a force, per race),
        ``<prefix>_force_speed.png`` (F_max against approach speed),
        ``<prefix>_iterations.png`` (Newton iterations per step and stage).
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    cols = _impact_columns(impacts_ds, run_ds, settle)
    return [
        _plot_force_angle(run_ds, cols, outdir / f"{prefix}_force_angle.png", settle, zero_tol,
                          zero_floor),
        _plot_ball_load(run_ds, cols, outdir / f"{prefix}_ball_load.png", settle),
        _plot_exceedance(run_ds, cols, outdir / f"{prefix}_exceedance.png", settle,
                         force_levels),
        _plot_force_speed(run_ds, cols, outdir / f"{prefix}_force_speed.png", settle),
        _plot_iterations(run_ds, cols, outdir / f"{prefix}_iterations.png", settle),
    ]


# --- the study: every grid point --------------------------------------------------------------

#: Largest page a study figure draws: panels (columns x rows) and cells along x or y. A larger
#: grid gets a page that says so (choose study.figure_axes, or fix more axes).
MAX_PANELS = 36
MAX_CELLS = 30
_MODEL_TITLES = {0: "the paper's method (nonsmooth)", 1: "compliant model (reference)"}


@dataclass
class StudyQuantity:
    """One quantity of the study figures: a DataArray over the grid's axes."""

    stem: str          # file name stem
    data: xr.DataArray
    label: str         # colour-bar label
    how: str           # reduction over the other axes in the pairs figure: max, mean, median
    kind: str = "plain"  # plain, or ratio (a diverging scale around 1)


@dataclass
class FigureLayout:
    """Which axis of the grid goes where in a study figure.

    Attributes
    ----------
    x, y : str or None
        Axes of each heat map (y None: one row of cells).
    col, row : str or None
        Axes of the panel columns and rows.
    fixed : dict
        Other swept axes, each held at a value {axis: value}.
    held : dict
        Axes of a single value {axis: value}.
    names : FigureSettingNames
        How the settings that choose the layout are named, on a page too large to draw.
    """

    x: str | None
    y: str | None = None
    col: str | None = None
    row: str | None = None
    fixed: dict = field(default_factory=dict)
    held: dict = field(default_factory=dict)
    names: FigureSettingNames = FIGURE_KEYS

    @property
    def axes(self) -> list[str]:
        return [a for a in (self.x, self.y, self.col, self.row) if a]


def grid_axes(summary_ds: xr.Dataset) -> list[str]:
    """The summary's grid axes (swept parameters), in its order."""
    from .summary import _ORDER

    return [d for d in summary_ds["failed"].dims if d not in _ORDER] if "failed" in summary_ds \
        else [d for d in summary_ds.dims if d not in _ORDER]


def _axis_value(summary_ds, axis, value, settings=FIGURE_KEYS) -> float:
    """The grid value of ``axis`` that ``value`` names: a number, or a category's name (its
    ``flag_meanings``) or code; a value the grid lacks is refused naming ``settings.held``."""
    values = np.asarray(summary_ds[axis].values, dtype=float)
    names = [_category(summary_ds, axis, v) for v in values]
    if isinstance(value, str) and value in names:
        return float(values[names.index(value)])
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = np.nan
    hit = np.flatnonzero(np.isclose(values, number, rtol=1e-9, atol=0.0))
    if not hit.size:
        allowed = ", ".join(name if name is not None else f"{v:g}"
                            for v, name in zip(values, names, strict=True))
        raise ValueError(f"{settings.held(axis)}: {value!r} is not allowed; allowed: one of the "
                         f"grid's values {allowed}")
    return float(values[hit[0]])


#: The summary's attribute that names the study's reference point (the grid point nearest its
#: ``model`` section, where heat maps hold an axis they do not draw): ``"clearance=0.0004
#: mu=0.01 ... bearing=6205"``, a category by its name.
REFERENCE_ATTRIBUTE = "study_reference"


def reference_attribute(reference: dict, summary_ds: xr.Dataset) -> str:
    """The text of :data:`REFERENCE_ATTRIBUTE` for ``{coordinate name: stored value}`` (a
    category's code, named by the summary's ``flag_meanings``)."""
    items = []
    for name, value in reference.items():
        category = _category(summary_ds, name, value) if name in summary_ds.coords else None
        items.append(f"{name}={category if category is not None else repr(float(value))}")
    return " ".join(items)


def stored_reference(summary_ds: xr.Dataset) -> dict | None:
    """``{coordinate name: value}`` (a category by its code) of the study's reference point a
    summary states (:data:`REFERENCE_ATTRIBUTE`), or None (a summary made without a study)."""
    text = summary_ds.attrs.get(REFERENCE_ATTRIBUTE)
    if not text:
        return None
    reference = {}
    for name, _, value in (item.partition("=") for item in str(text).split()):
        if _category(summary_ds, name, 0) is not None:  # a category, by its name ("6012")
            reference[name] = _axis_value(summary_ds, name, value)
        else:
            reference[name] = float(value)
    return reference


def _held_value(summary_ds: xr.Dataset, axis: str, reference=None) -> float:
    """Where a figure holds a swept ``axis`` it does not draw: the grid value nearest the
    study's reference point (``reference``, {axis: value}), else the middle value."""
    values = np.asarray(summary_ds[axis].values, dtype=float)
    if reference and axis in reference:
        return float(values[np.argmin(np.abs(values - float(reference[axis])))])
    return float(values[(values.size - 1) // 2])


def figure_layout(summary_ds: xr.Dataset, figure_axes=None, figure_fixed=None,
                  reference=None, names: FigureSettingNames = FIGURE_KEYS) -> FigureLayout:
    """The layout of the study figures (``study.figure_axes``, ``study.figure_fixed``).

    Parameters
    ----------
    summary_ds : xarray.Dataset
        The study summary.
    figure_axes : sequence of str, optional
        x, y, panel columns, panel rows (2 to 4 swept axes). Default: the first four swept
        axes of the summary, in its order.
    figure_fixed : dict, optional
        {axis: value} for swept axes not in ``figure_axes``: held at that grid value (a
        category's name or code, e.g. ``{"bearing": "6205"}``).
    reference : dict, optional
        {axis: value}: a swept axis neither drawn nor in ``figure_fixed`` is held at its grid
        value nearest this one (the study's reference point); without it, at its middle value.
    names : FigureSettingNames
        How errors and pages name the two settings: the study's keys (default), or a
        command's options (:data:`simcore.study.plan.FIGURE_OPTIONS`).

    Returns
    -------
    FigureLayout

    Raises
    ------
    ValueError
        One line naming the setting: an axis that is not a grid axis, named twice, or held at a
        value the grid does not have.
    """
    grid = grid_axes(summary_ds)
    swept = [a for a in grid if summary_ds.sizes[a] > 1]
    held = {a: float(summary_ds[a].values[0]) for a in grid if a not in swept}
    fixed_in = dict(figure_fixed or {})
    axes = check_figure_settings({a: summary_ds.sizes[a] for a in grid}, figure_axes, fixed_in,
                                 names)
    for a in held:
        if a in fixed_in:  # an axis of one value: held there anyway, but only at a grid value
            _axis_value(summary_ds, a, fixed_in[a], names)
    if not figure_axes:
        axes = [a for a in swept if a not in fixed_in][:4]
    fixed = {}
    for a in swept:
        if a in axes:
            continue
        if a in fixed_in:
            fixed[a] = _axis_value(summary_ds, a, fixed_in[a], names)
        else:
            fixed[a] = _held_value(summary_ds, a, reference)
    axes += [None] * (4 - len(axes))
    return FigureLayout(x=axes[0], y=axes[1], col=axes[2], row=axes[3], fixed=fixed,
                        held=held, names=names)


def _axis_label(ds, dim):
    """(label, unit shown, factor from SI) of a grid axis: known ones in the units a designer
    reads, others from the summary's attributes."""
    if dim in _PARAM:
        return _PARAM[dim]
    attrs = ds[dim].attrs if dim in ds.coords else {}
    unit = attrs.get("units", "")
    return attrs.get("long_name", dim), ("–" if unit in ("", "1") else unit), 1.0


def _category(ds, dim, value):
    """The name of a category axis's code (its ``flag_meanings``), else None."""
    meanings = ds[dim].attrs.get("flag_meanings") if dim in ds.coords else None
    if not meanings:
        return None
    names = str(meanings).split()
    code = int(round(float(value)))
    return names[code] if 0 <= code < len(names) else None


def _fmt_axis(ds, dim, value):
    if dim in _PARAM:
        return _fmt_param(dim, value)
    name = _category(ds, dim, value)
    if name is not None:
        return f"{dim} = {name}"
    label, unit, fac = _axis_label(ds, dim)
    unit_txt = "" if unit in ("", "–") else f" {unit}"
    return f"{dim} = {value * fac:.4g}{unit_txt}"


#: the bearing's ratings of the compliant twins drawn over the grid (stem: label)
_BEARING_RATINGS = {"L10h": "ISO 281 rating life L10 [h]",
                    "L10rh": "reference rating life L10r (ball loads) [h]",
                    "static_safety_factor": "ISO 76 static safety factor s0 = C0 / P0"}


def _study_quantities(summary_ds):
    """The quantities of the study figures (:class:`StudyQuantity`), for each model where the
    summary has a ``model`` dimension."""
    out = []
    s = summary_ds
    models = [int(m) for m in s["model"].values] if "model" in s.dims else [None]

    def per_model(da, m):
        return da if m is None else da.sel(model=m, drop=True)

    def suffix(m):
        return "" if m is None else f"_{CONTACT_MODELS[m]}"

    def who(m):
        return "" if m is None else f", {CONTACT_MODELS[m]}"

    for name, what in (("peak_force", "steady peak force"),
                       ("peak_force_rev_median", "median over revolutions of the peak force")):
        if name in s:
            for r in (1, 0):
                for m in models:
                    out.append(StudyQuantity(f"{name}_{RACE_NAMES[r]}{suffix(m)}",
                                             per_model(s[name], m).isel(race=r) / 1e3,
                                             f"{what}, {RACE_NAMES[r]} race{who(m)} [kN]", "max"))
    if "method_ratio" in s and bool(s["method_ratio"].notnull().any()):
        for r in (1, 0):
            out.append(StudyQuantity(f"method_ratio_{RACE_NAMES[r]}",
                                     s["method_ratio"].isel(race=r),
                                     f"nonsmooth / compliant peak force, {RACE_NAMES[r]} race",
                                     "median", "ratio"))
    if "static_deflection_ratio" in s and bool(s["static_deflection_ratio"].notnull().any()):
        out.append(StudyQuantity("static_deflection_ratio", s["static_deflection_ratio"],
                                 "static deflection of a ball / clearance", "max"))
    for name, what in (("p_max", "peak contact pressure p_max"),
                       ("p_max_groove", "peak contact pressure in a real groove")):
        if name not in s or not bool(s[name].notnull().any()):
            continue
        for r in (1, 0):
            for m in models:
                da = per_model(s[name], m).isel(race=r) / 1e6
                if bool(da.notnull().any()):
                    out.append(StudyQuantity(f"{name}_{RACE_NAMES[r]}{suffix(m)}", da,
                                             f"{what}, {RACE_NAMES[r]} race{who(m)} [MPa]",
                                             "max"))
    if "startup_peak_force" in s:
        for m in models:
            out.append(StudyQuantity(f"startup_peak_force{suffix(m)}",
                                     per_model(s["startup_peak_force"], m) / 1e3,
                                     f"start-up peak force (both races){who(m)} [kN]", "max"))
    if "above_per_rev" in s:
        for i, level in enumerate(s["level"].values):
            for m in models:
                da = per_model(s["above_per_rev"], m).isel(level=i).sum("race", min_count=1)
                what = "contact episodes" if m == 1 else "impacts"
                out.append(StudyQuantity(f"above_{level:g}N_per_rev{suffix(m)}", da,
                                         f"{what} per revolution with force ≥ "
                                         f"{_fmt_force(level)} (both races){who(m)}", "mean"))
    for name, what in _BEARING_RATINGS.items():
        if name in s and bool(s[name].notnull().any()):
            out.append(StudyQuantity(name, s[name], f"{what}, compliant model", "min"))
    if "impacts_per_rev" in s:
        da = s["impacts_per_rev"].sum(["race", "kind"], min_count=1)
        if "model" in da.dims:
            da = da.sel(model=0, drop=True)
        out.append(StudyQuantity("impacts_per_rev", da, "impacts per revolution (relative zero "
                                 "threshold, all kinds, nonsmooth)", "mean"))
    return out


def _positions(dim, values):
    """Where a swept value sits on its axis: clearance at its value (log axis), the others at
    equal steps (their values are uneven, e.g. mu = 0, 0.01, 0.05)."""
    values = np.asarray(values, dtype=float)
    return values if dim == "clearance" else np.arange(values.size, dtype=float)


def _ticks(ax, axis, ds, dim):
    label, unit, fac = _axis_label(ds, dim)
    values = np.asarray(ds[dim].values, dtype=float)
    text = [_category(ds, dim, v) or f"{v * fac:.3g}" for v in values]
    (ax.set_xticks if axis == "x" else ax.set_yticks)(_positions(dim, values), text)
    target = ax.xaxis if axis == "x" else ax.yaxis
    target.set_minor_locator(matplotlib.ticker.NullLocator())
    (ax.set_xlabel if axis == "x" else ax.set_ylabel)(f"{label} [{unit or '–'}]")


def _edges(dim, values):
    """Cell edges around the positions of :func:`_positions` (geometric means for clearance)."""
    v = _positions(dim, values)
    log = dim == "clearance"
    v = np.log10(v) if log else v
    if v.size == 1:
        edges = np.array([v[0] - 0.5, v[0] + 0.5])
    else:
        inner = 0.5 * (v[1:] + v[:-1])
        edges = np.r_[v[0] - (inner[0] - v[0]), inner, v[-1] + (v[-1] - inner[-1])]
    return 10**edges if log else edges


def _norm(values, kind="plain"):
    """Colour scale of a heat map: for a ratio, logarithmic and symmetric about 1; otherwise
    logarithmic for positive values spanning more than a factor of 10 (peak forces), square
    root for counts with zeros and a long tail, else linear."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if kind == "ratio":
        positive = values[values > 0]
        span = float(np.max(np.abs(np.log(positive)))) if positive.size else 0.0
        span = max(span, np.log(1.25))
        return matplotlib.colors.LogNorm(vmin=np.exp(-span), vmax=np.exp(span))
    if not values.size:
        return matplotlib.colors.Normalize(vmin=0.0, vmax=1.0)
    lo, hi = float(values.min()), float(values.max())
    if hi <= lo:
        return matplotlib.colors.Normalize(vmin=lo - 0.5, vmax=hi + 0.5)
    if lo > 0 and hi / lo > 10:
        return matplotlib.colors.LogNorm(vmin=lo, vmax=hi)
    if lo >= 0 and hi > 10 * np.median(values[values > 0]):
        return matplotlib.colors.PowerNorm(gamma=0.5, vmin=lo, vmax=hi)
    return matplotlib.colors.Normalize(vmin=lo, vmax=hi)


def _cmap(kind):
    return plt.get_cmap("RdBu_r" if kind == "ratio" else "viridis").with_extremes(bad="0.85")


#: Width of a character of a figure title (11 pt) and of a colour-bar label (10 pt) [in].
_TITLE_CHAR = 0.085
_LABEL_CHAR = 0.075


def _title_width(title: str) -> float:
    """Width a figure title needs [in]."""
    return _TITLE_CHAR * max(len(line) for line in title.splitlines()) + 0.4


def _panel_grid(nrow, ncol, panel_w, panel_h, wgap, hgap, *, left=0.85, right=1.3,
                bottom=0.65, top=0.95, min_width=0.0, **subplot_kw):
    """Figure of ``nrow`` x ``ncol`` panels of ``panel_w`` x ``panel_h`` inches, ``wgap`` and
    ``hgap`` inches apart, with margins fixed in inches (``left`` for the tick labels and the
    axis label, ``bottom`` likewise, ``top`` for the titles, ``right`` for the colour bar), and
    the colour bar's axes. Returns ``(fig, axes, cax)``.

    A layout engine that measures every text to place the panels (matplotlib's constrained
    layout) took some 40 % of the time of drawing a study figure, and the study's figures are
    the last job of the study; its panels and labels have known sizes, so fixed margins do.
    """
    width = left + ncol * panel_w + (ncol - 1) * wgap + right
    if width < min_width:  # room for the title: the panels stay centred
        left, right = left + 0.5 * (min_width - width), right + 0.5 * (min_width - width)
        width = min_width
    height = bottom + nrow * panel_h + (nrow - 1) * hgap + top
    fig, axes = plt.subplots(nrow, ncol, figsize=(width, height), squeeze=False,
                             gridspec_kw={"left": left / width, "right": 1 - right / width,
                                          "bottom": bottom / height, "top": 1 - top / height,
                                          "wspace": wgap / panel_w, "hspace": hgap / panel_h},
                             **subplot_kw)
    span = nrow * panel_h + (nrow - 1) * hgap
    cax = fig.add_axes((1 - (right - 0.25) / width, (bottom + 0.05 * span) / height,
                        0.22 / width, 0.9 * span / height))
    return fig, axes, cax


#: Tick values of a ratio's colour bar (those inside its range are shown).
_RATIO_TICKS = (0.2, 0.25, 1 / 3, 0.5, 2 / 3, 0.8, 1.0, 1.25, 1.5, 2.0, 3.0, 4.0, 5.0)


def _colorbar(fig, mesh, cax, label, kind="plain"):
    """Colour bar in ``cax`` with plain-number ticks (1, 2, 5 per decade on a log scale; a
    ratio's about 1), its label wrapped to the bar's length."""
    import textwrap

    span = cax.get_position().height * fig.get_figheight()
    width = max(20, int(span / _LABEL_CHAR))
    bar = fig.colorbar(mesh, cax=cax, label="\n".join(textwrap.wrap(label, width)))
    if kind == "ratio":
        lo, hi = mesh.norm.vmin, mesh.norm.vmax
        bar.set_ticks([t for t in _RATIO_TICKS if lo <= t <= hi])
        bar.ax.yaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        bar.ax.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:.2g}"))
        return bar
    if isinstance(mesh.norm, matplotlib.colors.LogNorm):
        bar.ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        bar.ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    bar.ax.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    return bar


def _heat_panel(ax, da, x, y, norm, cmap, failed):
    """One heat map of ``da`` (dims y, x) with every cell's value written in it."""
    xv, yv = _positions(x, da[x].values), _positions(y, da[y].values)
    z = np.ma.masked_invalid(da.transpose(y, x).values.astype(float))
    mesh = ax.pcolormesh(_edges(x, da[x].values), _edges(y, da[y].values), z, norm=norm,
                         cmap=cmap)
    for dim, setter in ((x, ax.set_xscale), (y, ax.set_yscale)):
        if dim == "clearance":
            setter("log")
    bad = failed.transpose(y, x).values if failed is not None else np.zeros(z.shape, bool)
    for j, yy in enumerate(yv):
        for i, xx in enumerate(xv):
            if bad[j, i]:
                txt, colour = "failed", "k"
            elif np.ma.is_masked(z[j, i]):
                txt, colour = "–", "k"
            else:
                val = float(z[j, i])
                txt = f"{val:.0f}" if 1e3 <= abs(val) < 1e6 else f"{val:.3g}"
                rgba = cmap(norm(val))
                light = 0.299 * rgba[0] + 0.587 * rgba[1] + 0.114 * rgba[2]
                colour = "k" if light > 0.5 else "w"
            ax.text(xx, yy, txt, ha="center", va="center", fontsize=8, color=colour,
                    in_layout=False)
    return mesh


def _too_large(path, title, message):
    """A page that says why the figure is not drawn."""
    fig = plt.figure(figsize=(8, 2.5))
    fig.text(0.03, 0.6, title, fontsize=10, va="center")
    fig.text(0.03, 0.3, message, fontsize=10, va="center", color="tab:red", wrap=True)
    return _save(fig, path, dpi=100)


def _facet_figure(q: StudyQuantity, layout: FigureLayout, ds, path, failed, title):
    """Every grid point of the layout's axes: heat maps of x and y, panels by col and row."""
    da = q.data
    x, y, col, row = layout.x, layout.y, layout.col, layout.row
    ncol = da.sizes[col] if col else 1
    nrow = da.sizes[row] if row else 1
    cells = max(da.sizes[x], da.sizes[y] if y else 1)
    if ncol * nrow > MAX_PANELS or cells > MAX_CELLS:
        return _too_large(path, title, (
            f"not drawn: {nrow} x {ncol} panels of {da.sizes[x]} x "
            f"{da.sizes[y] if y else 1} cells exceed {MAX_PANELS} panels or {MAX_CELLS} cells "
            f"a side; choose {layout.names.axes} or fix axes with {layout.names.fixed}"))
    norm = _norm(da.values, q.kind)
    cmap = _cmap(q.kind)
    fig, axes, cax = _panel_grid(nrow, ncol, 3.1, 2.4, 0.15, 0.35, sharex=True, sharey=True,
                                 min_width=_title_width(title))
    mesh = None
    for i in range(nrow):
        for j in range(ncol):
            ax = axes[i, j]
            sel = {d: k for d, k in ((row, i), (col, j)) if d}
            sub = da.isel(sel)
            fsub = failed.isel(sel) if failed is not None else None
            if y is None:
                sub = sub.expand_dims(_y=[0.0])
                fsub = fsub.expand_dims(_y=[0.0]) if fsub is not None else None
                mesh = _heat_panel(ax, sub, x, "_y", norm, cmap, fsub)
                ax.set_yticks([])
            else:
                mesh = _heat_panel(ax, sub, x, y, norm, cmap, fsub)
            heads = [_fmt_axis(ds, d, float(da[d].values[k])) for d, k in ((row, i), (col, j))
                     if d]
            ax.set_title(", ".join(heads), fontsize=9)
            if i == nrow - 1:
                _ticks(ax, "x", da, x)
            if j == 0 and y is not None:
                _ticks(ax, "y", da, y)
    _colorbar(fig, mesh, cax, q.label, q.kind)
    fig.suptitle(title, fontsize=11)
    return _save(fig, path, dpi=100)


def _reduce(da, dims, how):
    if not dims:
        return da
    return getattr(da, how)(dims, skipna=True)


def _pairs_figure(q: StudyQuantity, swept, ds, path, failed, title, names=FIGURE_KEYS):
    """One heat map per pair of swept dims, the others reduced (max, mean or median)."""
    pairs = [(a, b) for i, a in enumerate(swept) for b in swept[i + 1:]]
    widest = max(q.data.sizes[a] for a in swept)
    if len(pairs) > MAX_PANELS or widest > MAX_CELLS:
        return _too_large(path, title, (
            f"not drawn: {len(pairs)} pairs of axes of up to {widest} values exceed "
            f"{MAX_PANELS} panels or {MAX_CELLS} cells a side; fix axes with {names.fixed}"))
    ncol = min(3, len(pairs))
    nrow = int(math.ceil(len(pairs) / ncol))
    masked = q.data.where(~failed) if failed is not None else q.data
    reduced = {(a, b): _reduce(masked, [d for d in swept if d not in (a, b)], q.how)
               for a, b in pairs}
    norm = _norm(np.concatenate([np.ravel(r.values) for r in reduced.values()]), q.kind)
    cmap = _cmap(q.kind)
    fig, axes, cax = _panel_grid(nrow, ncol, 3.4, 2.7, 0.95, 0.8, min_width=_title_width(title))
    mesh = None
    for ax, (a, b) in zip(axes.ravel(), pairs, strict=False):
        xdim, ydim = (b, a) if a != "clearance" and b == "clearance" else (a, b)
        mesh = _heat_panel(ax, reduced[(a, b)], xdim, ydim, norm, cmap, None)
        _ticks(ax, "x", ds, xdim)
        _ticks(ax, "y", ds, ydim)
        rest = [d for d in swept if d not in (a, b)]
        ax.set_title(f"{q.how} over {', '.join(rest)}" if rest else "", fontsize=9)
    for ax in axes.ravel()[len(pairs):]:
        ax.set_axis_off()
    _colorbar(fig, mesh, cax, q.label, q.kind)
    fig.suptitle(title, fontsize=11)
    return _save(fig, path, dpi=100)


def _line_figure(q: StudyQuantity, dim, ds, path, failed, title):
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    da = q.data
    x = _positions(dim, da[dim].values)
    ax.plot(x, da.values.astype(float), "o-")
    if failed is not None and bool(failed.any()):
        for xx in x[failed.values.astype(bool)]:
            ax.axvline(xx, color="r", ls=":", lw=1)
    if q.kind == "ratio":
        ax.axhline(1.0, color="0.5", lw=1)
    if dim == "clearance":
        ax.set_xscale("log")
    _ticks(ax, "x", ds, dim)
    ax.set_ylabel(q.label)
    ax.grid(alpha=0.3)
    ax.set_title(title, fontsize=10)
    return _save(fig, path, dpi=100)


def _single_figure(summary_ds, quantities, held, path):
    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    sel = {d: 0 for d in held}
    lines = [", ".join(_fmt_axis(summary_ds, d, v) for d, v in held.items())]
    lines += [f"{q.label}: {float(q.data.isel(sel).values):.4g}" for q in quantities]
    ax.text(0.02, 0.5, "\n".join(lines), va="center", transform=ax.transAxes, fontsize=9)
    ax.set_axis_off()
    ax.set_title("Study: a single parameter set (nothing swept)")
    return _save(fig, path)


def _failed_mask(summary_ds, model):
    if "failed" not in summary_ds:
        return None
    failed = summary_ds["failed"] > 0
    if "model" in failed.dims:
        failed = failed.sel(model=model, drop=True) if model is not None else failed.any("model")
    return failed


def _quantity_model(q: StudyQuantity):
    if q.stem in _BEARING_RATINGS:
        return 1
    for m, name in enumerate(CONTACT_MODELS):
        if q.stem.endswith(f"_{name}"):
            return m
    return None


def plot_study(summary_ds: xr.Dataset, outdir, part: tuple[int, int] = (0, 1),
               figure_axes=None, figure_fixed=None, reference=None, model=None,
               names: FigureSettingNames = FIGURE_KEYS) -> list[Path]:
    """Every grid point of the study: heat maps of peak forces of both models, their ratio,
    p_max and counts.

    Parameters
    ----------
    summary_ds : xarray.Dataset
        The study summary (:func:`analysis.summary.summarize`): the grid's axes (any swept
        parameters), ``model``, ``race``, ``level``, ...
    outdir : str or Path
        Output folder (created).
    part : (int, int)
        ``(i, n)``: draw only the quantities i, i + n, i + 2n, ... (so that n processes can
        share the work); the default draws all.
    figure_axes, figure_fixed, reference, names :
        The layout (:func:`figure_layout`; ``study.figure_axes``, ``study.figure_fixed``, the
        study's reference point, how messages name the two settings).
    model : {None, "nonsmooth", "compliant"}
        Draw only that model's quantities; None (default): both models, their ratio and the
        static deflection ratio.

    Returns
    -------
    list of Path
        For each quantity (peak force, its median over revolutions and p_max per race and
        model, the method ratio per race, the static deflection ratio, start-up peak, counts
        per revolution above each force level, impacts per revolution): ``study_<quantity>.png``
        with every grid point of the layout (x, y: heat-map axes, clearance on a log axis;
        panel columns and rows; the other axes held at one value, said in the title; the value
        written in each cell; "failed" where the run failed), or a page saying that the grid is
        too large to draw (:data:`MAX_PANELS`, :data:`MAX_CELLS`); with three or more swept
        axes also ``pairs_<quantity>.png``: one heat map per pair of swept axes, the largest
        (peaks), mean (counts) or median (ratios) over the others. With one swept axis a line
        plot, with none ``study_single.png``.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    index, parts = (int(x) for x in part)
    if not (parts >= 1 and 0 <= index < parts):
        raise ValueError(f"part: {part!r} is not allowed; allowed: (i, n) with 0 <= i < n")
    layout = figure_layout(summary_ds, figure_axes, figure_fixed, reference, names)
    quantities = _study_quantities(summary_ds)
    if model is not None:
        if model not in CONTACT_MODELS:
            raise ValueError(f"model: {model!r} is not allowed; allowed: None, "
                             f"{', '.join(CONTACT_MODELS)}")
        quantities = [q for q in quantities if _quantity_model(q) == CONTACT_MODELS.index(model)]
    if not layout.x:
        return [] if index > 0 else [_single_figure(summary_ds, quantities, layout.held,
                                                    outdir / "study_single.png")]
    swept = [a for a in grid_axes(summary_ds) if summary_ds.sizes[a] > 1]
    paths = []
    by_clearance = "clearance" in swept or ("clearance_class" in swept
                                            and "clearance" in summary_ds.coords)
    if index == 0 and model in (None, "compliant") and "L10h" in summary_ds \
            and by_clearance and bool(summary_ds["L10h"].notnull().any()):
        paths.append(plot_life(summary_ds, outdir / "life_clearance_speed.png", layout,
                               reference=reference))
    for q in quantities[index::parts]:
        paths += _quantity_figures(summary_ds, q, layout, swept, outdir)
    return paths


def _number(value) -> str:
    """A number as ``:g`` formats it; a name (a swept setting's axis) as it is."""
    return value if isinstance(value, str) else f"{value:g}"


def _quantity_figures(summary_ds, q: StudyQuantity, layout: FigureLayout, swept, outdir):
    """``study_<stem>.png`` of one quantity over the layout, and ``pairs_<stem>.png`` with three
    or more swept axes."""
    settle = summary_ds.attrs.get("settle_revolutions", summary_ds.attrs.get("analysis_settle"))
    if settle is None and "analysis_settle" in summary_ds.coords:  # swept: an axis of the grid
        settle = "analysis_settle"
    held = ", ".join(_fmt_axis(summary_ds, d, v) for d, v in {**layout.held,
                                                              **layout.fixed}.items())
    held = f"; {held}" if held else ""
    at = {d: 0 for d in layout.held}
    full = q.data.isel(at)
    failed_full = _failed_mask(summary_ds, _quantity_model(q))
    failed_full = failed_full.isel(at) if failed_full is not None else None
    q_fixed = StudyQuantity(q.stem, full.sel(layout.fixed), q.label, q.how, q.kind)
    failed = failed_full.sel(layout.fixed) if failed_full is not None else None
    if settle is None:
        note = held[2:]
    elif q.stem.startswith("startup"):
        note = f"start-up: the first {_number(settle)} crank revolution(s) of each run{held}"
    else:
        note = f"steady window: after the first {_number(settle)} crank revolution(s){held}"
    title = f"{q.label}: every grid point" + (f"\n({note})" if note else "")
    path = outdir / f"study_{q.stem}.png"
    if not layout.y and not layout.col:
        paths = [_line_figure(q_fixed, layout.x, summary_ds, path, failed, title)]
    else:
        q_fixed.data = q_fixed.data.transpose(*layout.axes)
        paths = [_facet_figure(q_fixed, layout, summary_ds, path,
                               failed.transpose(*layout.axes) if failed is not None else None,
                               title)]
    if len(swept) >= 3:
        note = f"\n(steady window: after the first {_number(settle)} crank revolution(s))" \
            if settle is not None and not q.stem.startswith("startup") else ""
        paths.append(_pairs_figure(
            StudyQuantity(q.stem, full.transpose(*swept), q.label, q.how, q.kind), swept,
            summary_ds, outdir / f"pairs_{q.stem}.png",
            failed_full.transpose(*swept) if failed_full is not None else None,
            f"{q.label}: each pair of swept parameters, {q.how} over the others{note}",
            layout.names))
    return paths


#: Bore of the bearing whose ISO 5753-1 clearance classes the life figure marks, where the
#: summary does not name its bearing: the paper's 6012 [mm].
DEFAULT_BORE = 60.0


def _bore(summary_ds, at=None) -> float:
    """Bore [mm] of the bearing drawn: its catalogue entry's, the entry being the value at
    which ``at`` holds a swept ``bearing`` axis, else the study's ``model.bearing`` (the
    summary's attribute ``model_bearing``), else :data:`DEFAULT_BORE`."""
    from simcore.model.bearing import bearing

    name = summary_ds.attrs.get("model_bearing")
    if at and "bearing" in at:
        name = _category(summary_ds, "bearing", at["bearing"])
    return float(bearing(str(name))["d"]) if name is not None else DEFAULT_BORE


def _class_bands(ax, bore):
    """Mark the model clearance g of each ISO 5753-1 class of a bore (half the class's radial
    internal clearance, docs/life.md): a bar per class along the top of the axes (the classes
    overlap), a dotted line at its middle."""
    from simcore.model.bearing import CLEARANCE_CLASSES, clearance_range

    top = ax.get_xaxis_transform()  # x in data, y in axes fraction
    for i, name in enumerate(CLEARANCE_CLASSES):
        try:
            lo, hi, mid = clearance_range(bore, name)
        except ValueError:  # a class the table does not give for this bore
            continue
        y = 0.96 - 0.06 * i
        ax.plot([lo / 2 * 1e6, hi / 2 * 1e6], [y, y], color="0.45", lw=3, transform=top,
                solid_capstyle="butt")
        ax.text(hi / 2 * 1e6 * 1.08, y, name, transform=top, va="center", fontsize=8,
                color="0.3")
        ax.axvline(mid / 2 * 1e6, color="0.6", lw=0.8, ls=":", zorder=0)


def plot_life(summary_ds: xr.Dataset, path, layout: FigureLayout | None = None,
              bore: float | None = None, reference=None) -> Path:
    """Rating lives against clearance, one line per crank speed (the compliant twins' L10h and
    L10rh), with the ISO 5753-1 clearance classes of the bearing's bore marked.

    Parameters
    ----------
    summary_ds : xarray.Dataset
        A study summary with ``L10h``, ``L10rh`` and a ``clearance`` axis, or a
        ``clearance_class`` axis with the clearance of each class as a coordinate.
    path : str or Path
        Output file.
    layout : FigureLayout, optional
        Values at which the other swept axes are held (:func:`figure_layout`; default: its
        defaults).
    bore : float, optional
        Bore of the bearing [mm] for the class bands (default: that of the catalogue entry
        drawn, a swept bearing held where the layout holds it, else the one the summary's
        attribute ``model_bearing`` names, else :data:`DEFAULT_BORE`).
    reference : dict, optional
        {axis: value} of the study's reference point: an axis the layout does not hold (one
        the heat maps draw) is held at its grid value nearest this one, else at its middle
        value.

    Returns
    -------
    Path
    """
    layout = layout or figure_layout(summary_ds, reference=reference)
    keep = {"clearance", "clearance_class", "omega0"}  # (a class: its clearance along it)
    at = {}  # every other axis held: where the layout holds it, else at the reference point
    for d in grid_axes(summary_ds):
        if d not in keep:
            at[d] = {**layout.held, **layout.fixed}.get(d, _held_value(summary_ds, d, reference))
    bore = float(bore or _bore(summary_ds, at))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True, layout="constrained")
    for ax, name, what in ((axes[0], "L10h", "ISO 281 L10 (transmitted load)"),
                           (axes[1], "L10rh", "reference L10r (ball loads)")):
        da = summary_ds[name].sel(at)
        speeds = da["omega0"].values if "omega0" in da.dims else [None]
        for speed in speeds:
            line = da.sel(omega0=speed) if speed is not None else da
            label = f"ω0 = {float(speed):g} rad/s" if speed is not None else None
            ax.plot(line["clearance"].values * 1e6, line.values, "o-", label=label)
        _class_bands(ax, bore)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("clearance g [µm]")
        ax.set_title(what, fontsize=10)
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("rating life [h]")
    if len(speeds) > 1:
        axes[1].legend(fontsize=8)
    held = ", ".join(_fmt_axis(summary_ds, d, v) for d, v in at.items())
    classes = f"bars: the ISO 5753-1 classes of a {bore:g} mm bore as the model's clearance"
    fig.suptitle("Rating life of the bearing from the compliant model's loads, steady window"
                 + (f"\n({held}; {classes})" if held else f"\n({classes})"), fontsize=10)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return Path(path)
