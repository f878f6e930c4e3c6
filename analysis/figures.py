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
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from .filtering import impact_masks, split_impulses, zero_threshold  # noqa: E402
from .impacts import STUDY_PARAMETERS  # noqa: E402

__all__ = ["plot_run", "plot_study", "run_label", "run_prefix"]

_PARAM = {
    # name: (label, unit shown, factor from SI)
    "clearance": ("clearance g", "µm", 1e6),
    "mu": ("friction μ", "–", 1.0),
    "omega0": ("crank speed ω0", "rad/s", 1.0),
    "e_N": ("restitution e_N", "–", 1.0),
}


def _param_value(ds, name):
    if name in ds.coords and ds[name].ndim == 0:
        return float(ds[name].values)
    key = f"model.{name}"
    if key in ds.attrs:
        return float(ds.attrs[key])
    return None


def _fmt_param(name, value):
    label, unit, fac = _PARAM.get(name, (name, "", 1.0))
    short = label.split()[-1]
    unit_txt = "" if unit in ("", "–") else f" {unit}"
    return f"{short} = {value * fac:.4g}{unit_txt}"


def run_label(ds) -> str:
    """Human-readable parameters of a run, e.g. ``g = 400 µm, μ = 0.01, ω0 = 50 rad/s, e_N = 0.9``.

    Parameters
    ----------
    ds : xarray.Dataset
        A run or impact dataset with the study parameters as scalar coords or ``model.*`` attrs.

    Returns
    -------
    str
    """
    parts = []
    for name in STUDY_PARAMETERS:
        v = _param_value(ds, name)
        if v is not None:
            parts.append(_fmt_param(name, v))
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
    parts = []
    for name in STUDY_PARAMETERS:
        v = _param_value(ds, name)
        if v is not None:
            parts.append(f"{name}{v:g}")
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
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


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
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _plot_slider(run_ds, path):
    needed = ("slider_x", "crank_angle")
    if any(n not in run_ds for n in needed):
        warnings.warn("run has no slider_x/crank_angle: slider figure skipped", stacklevel=3)
        return None
    try:
        L1 = float(run_ds.attrs["model.crank_length"])
        L2 = float(run_ds.attrs["model.rod_length"])
    except KeyError:
        warnings.warn("run lacks model.crank_length/rod_length: slider figure skipped",
                      stacklevel=3)
        return None
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
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_run(run_ds: xr.Dataset, impacts_ds: xr.Dataset | None, outdir, zero_tol=1e-4,
             zero_floor=1e-12, prefix=None, contact=None) -> list[Path]:
    """Figures of one run.

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run (SPEC section 5).
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


def _axis_values(ds, dim):
    label, unit, fac = _PARAM.get(dim, (dim, "", 1.0))
    return np.asarray(ds[dim].values, dtype=float) * fac, f"{label} [{unit or '–'}]"


def plot_study(summary_ds: xr.Dataset, outdir) -> list[Path]:
    """Peak force and impact counts against each swept parameter.

    Parameters
    ----------
    summary_ds : xarray.Dataset
        Dims among ``clearance``, ``mu``, ``omega0``, ``e_N`` (and ``rank``), variables
        ``peak_force`` [N], ``n_simple``, ``n_persistent`` (NaN marks a failed run).
    outdir : str or Path
        Output folder (created).

    Returns
    -------
    list of Path
        One ``study_<dim>.png`` per swept dim of length > 1: peak force (top) and counts
        (bottom) against it, one line per value of the first other swept dim of length > 1;
        the remaining dims are held at their middle value (index len // 2), named in the title.
        If no dim has length > 1, one ``study_single.png`` with the single run's values.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    dims = [d for d in STUDY_PARAMETERS if d in summary_ds.dims]
    dims += [d for d in summary_ds.dims if d not in dims and d != "rank"]
    swept = [d for d in dims if summary_ds.sizes[d] > 1]
    thr_note = ""
    if "zero_tol" in summary_ds.attrs:
        thr_note = f"; counts with zero_tol = {summary_ds.attrs['zero_tol']:g}"
    paths = []
    if not swept:
        path = outdir / "study_single.png"
        fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
        sub = summary_ds.isel({d: 0 for d in dims})
        lines = [run_label(sub)]
        for var, unit in (("peak_force", "N"), ("n_simple", ""), ("n_persistent", "")):
            if var in sub:
                lines.append(f"{var} = {float(sub[var].values):.4g} {unit}".rstrip())
        ax.text(0.05, 0.5, "\n".join(lines), va="center", transform=ax.transAxes)
        ax.set_axis_off()
        ax.set_title("Study: a single parameter set (nothing swept)")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        return [path]
    for dim in swept:
        others = [d for d in swept if d != dim]
        line_dim = others[0] if others else None
        fixed = {d: summary_ds.sizes[d] // 2 for d in dims if d not in (dim, line_dim)}
        sub = summary_ds.isel(fixed)
        x, xlabel = _axis_values(sub, dim)
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 8), sharex=True, layout="constrained")
        line_idx = range(sub.sizes[line_dim]) if line_dim else [None]
        any_data = False
        for i, li in enumerate(line_idx):
            cur = sub.isel({line_dim: li}) if line_dim else sub
            col = f"C{i % 10}"
            lab = (_fmt_param(line_dim, float(cur[line_dim].values)) if line_dim else None)
            if "peak_force" in cur:
                pf = np.asarray(cur["peak_force"].transpose(dim).values, dtype=float)
                any_data |= bool(np.isfinite(pf).any())
                a1.plot(x, pf / 1e3, "o-", color=col, label=lab)
            for var, ls in (("n_simple", "-"), ("n_persistent", "--")):
                if var in cur:
                    n = np.asarray(cur[var].transpose(dim).values, dtype=float)
                    any_data |= bool(np.isfinite(n).any())
                    a2.plot(x, n, "o" + ls, color=col,
                            label=(f"{var.split('_')[1]}" + (f", {lab}" if lab else "")))
        if not any_data:
            for ax in (a1, a2):
                ax.text(0.5, 0.5, "no valid runs (all NaN)", ha="center", va="center",
                        transform=ax.transAxes, color="r")
        a1.set_ylabel("peak force F_max [kN]")
        a2.set_ylabel("number of impacts [–]")
        a2.set_xlabel(xlabel)
        for ax in (a1, a2):
            ax.grid(alpha=0.3)
            if ax.get_legend_handles_labels()[0] and (line_dim or ax is a2):
                ax.legend(fontsize=8)
        fixed_txt = ", ".join(_fmt_param(d, float(sub[d].values)) for d in fixed
                              if d in sub.coords)
        notes = ([f"held: {fixed_txt}"] if fixed_txt else []) + ([thr_note[2:]] if thr_note else [])
        a1.set_title(f"Peak force and impact counts vs {_PARAM.get(dim, (dim,))[0]}"
                     + (f"\n({'; '.join(notes)})" if notes else ""))
        a2.set_title("solid: simple impacts, dashed: impacts on persistent contact", fontsize=9)
        path = outdir / f"study_{dim}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
