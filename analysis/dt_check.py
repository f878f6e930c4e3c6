"""Step-size check of the largest impacts: rerun a run at dt/2 and compare.

``python -m analysis dt-check RUN.nc [--t-check T] [--tol 0.1] [-n 6] [--out IMPACTS.nc]``

The run's configuration is rebuilt from the file's global attributes (``simcore.io`` writes every
``model.*``, ``solver.*`` and ``analysis.*`` setting there), ``solver.dt`` is halved (and
``solver.t_end`` cut to ``t_check`` if given), the run is simulated again, and the impacts of
both runs (over the same time window) are extracted with the same settings. The ``n`` largest
impacts of the original run (by F_max, by impulse where there is no force) are matched in the
finer run: same contact, time within two original steps, the largest impulse among the
candidates. Impulse, v_pre and F_max are compared; an impact whose relative change exceeds the
tolerance, or that has no match, is flagged ``not_converged_dt`` in the original table.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from .impacts import FLAG, extract_impacts, kind_name, race_name

__all__ = ["config_from_run", "compare_impacts", "dt_check", "format_dt_check"]

_COMPARED = ("impulse", "v_pre", "F_max")


def config_from_run(run_ds: xr.Dataset, overrides=None) -> dict:
    """The validated configuration of a run, rebuilt from its global attributes.

    Parameters
    ----------
    run_ds : xarray.Dataset
        A run written by ``simcore`` (attributes ``model.<key>``, ``solver.<key>``,
        ``analysis.<key>``).
    overrides : dict, optional
        ``{"solver.dt": 5e-5, ...}`` applied on top.

    Returns
    -------
    dict
        Configuration validated by :func:`simcore.validate_config`.

    Raises
    ------
    ValueError
        If the file holds no model or solver settings, or they do not validate.
    """
    from simcore import ConfigError, load_schema, validate_config

    schema = load_schema()
    cfg: dict = {}
    values = {k: v for k, v in run_ds.attrs.items() if "." in k}
    if values.get("solver.output_dt") == values.get("solver.dt"):
        # output at every step: stays so at another dt (the default, null)
        values.pop("solver.output_dt", None)
    values.update(overrides or {})
    for name, value in values.items():
        section, key = name.split(".", 1)
        props = schema["properties"].get(section, {}).get("properties", {})
        if section not in ("model", "solver", "analysis") or key not in props:
            continue
        typ = props[key].get("type")
        if isinstance(value, np.ndarray):
            value = value.tolist()
        elif isinstance(value, np.generic):
            value = value.item()
        if typ == "boolean":
            value = bool(int(value))
        elif typ == "integer":
            value = int(value)
        elif typ == "number":
            value = float(value)
        elif typ == "string":
            value = str(value)
        cfg.setdefault(section, {})[key] = value
    if "model" not in cfg or "solver" not in cfg:
        raise ValueError("run file has no 'model.*'/'solver.*' attributes: cannot rebuild its "
                         "configuration")
    try:
        return validate_config(cfg)
    except ConfigError as exc:
        raise ValueError(f"configuration rebuilt from the run file does not validate: {exc}") \
            from None


def _rank(table: xr.Dataset, n: int) -> np.ndarray:
    f = np.asarray(table["F_max"].values, dtype=float)
    imp = np.asarray(table["impulse"].values, dtype=float)
    key = np.where(np.isfinite(f), f, -np.inf)
    order = np.lexsort((-imp, -key))
    return order[:n]


def compare_impacts(coarse: xr.Dataset, fine: xr.Dataset, n=6, tol=0.1, window_steps=2.0):
    """Match the largest impacts of ``coarse`` in ``fine`` and flag those that moved.

    Parameters
    ----------
    coarse, fine : xarray.Dataset
        Impact tables (:func:`analysis.extract_impacts`) of the same run at dt and at a smaller
        step.
    n : int
        How many of the largest impacts of ``coarse`` to compare.
    tol : float
        Largest accepted relative change of impulse, v_pre and F_max [-].
    window_steps : float
        Time window of the match, in steps of ``coarse`` (attribute ``h``).

    Returns
    -------
    flagged : xarray.Dataset
        ``coarse`` with ``not_converged_dt`` set on the rows that moved or found no match,
        ``trusted`` updated, attributes ``dt_check = 1``, ``dt_check_tol``, ``dt_check_h_fine``.
    matches : list of dict
        Per compared impact: its row, the matched row (or None), values and relative changes.
    """
    if not (isinstance(n, int | np.integer) and n >= 1):
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    if not (math.isfinite(float(tol)) and tol > 0):
        raise ValueError(f"tol must be finite and > 0, got {tol!r}")
    h = float(coarse.attrs["h"])
    t_f = np.asarray(fine["time"].values, dtype=float)
    c_f = np.asarray(fine["contact"].values)
    imp_f = np.asarray(fine["impulse"].values, dtype=float)
    flags = np.asarray(coarse["flags"].values).copy()
    matches = []
    for i in _rank(coarse, n):
        row = coarse.isel(impact=int(i))
        t = float(row["time"])
        cand = np.flatnonzero((c_f == int(row["contact"]))
                              & (np.abs(t_f - t) <= window_steps * h + 1e-12))
        entry = {"row": int(i), "contact": int(row["contact"]), "ball": int(row["ball"]),
                 "race": race_name(row["race"]), "kind": kind_name(row["kind"]), "time": t,
                 "match": None, "moved": True}
        for name in _COMPARED:
            entry[name] = float(row[name])
        if cand.size:
            j = int(cand[np.argmax(imp_f[cand])])
            other = fine.isel(impact=j)
            entry["match"] = j
            entry["time_fine"] = float(other["time"])
            entry["kind_fine"] = kind_name(other["kind"])
            moved = False
            for name in _COMPARED:
                a, b = entry[name], float(other[name])
                rel = (b - a) / abs(a) if a != 0 and np.isfinite(a) and np.isfinite(b) else math.nan
                entry[f"{name}_fine"] = b
                entry[f"{name}_rel"] = rel
                if not (np.isfinite(rel) and abs(rel) <= tol):
                    # a force that is missing in both runs (no approach) does not count
                    if not (name == "F_max" and not np.isfinite(a) and not np.isfinite(b)):
                        moved = True
            entry["moved"] = moved
        if entry["moved"]:
            flags[i] |= FLAG["not_converged_dt"]
        matches.append(entry)
    out = coarse.copy()
    out["flags"] = ("impact", flags, coarse["flags"].attrs)
    trusted = (flags == 0) & np.isfinite(np.asarray(coarse["F_max"].values, dtype=float))
    out["trusted"] = ("impact", trusted.astype(np.int8), coarse["trusted"].attrs)
    out.attrs.update({
        "dt_check": 1,
        "dt_check_tol": float(tol),
        "dt_check_n": int(n),
        "dt_check_h_fine": float(fine.attrs["h"]),
        "n_flagged": int((flags != 0).sum()),
        "n_trusted": int(trusted.sum()),
    })
    return out, matches


def dt_check(run_ds: xr.Dataset, t_check=None, tol=0.1, n=6, **extract_kwargs):
    """Rerun a run at dt/2 (optionally only its first ``t_check`` seconds) and compare impacts.

    Parameters
    ----------
    run_ds : xarray.Dataset
        A run written by ``simcore``.
    t_check : float, optional
        Compare only the first ``t_check`` seconds [s] (the rerun stops there); None or 0: the
        whole run.
    tol : float
        Relative tolerance [-].
    n : int
        Number of largest impacts compared.
    **extract_kwargs
        Settings of :func:`analysis.extract_impacts` (zero_tol, r_eff, ...).

    Returns
    -------
    flagged, matches, fine_run
        See :func:`compare_impacts`; ``fine_run`` is the rerun dataset.
    """
    import simcore

    cfg = config_from_run(run_ds)
    dt = float(cfg["solver"]["dt"])
    t_end = float(cfg["solver"]["t_end"])
    if t_check is not None and t_check != 0:  # 0, as in the config: the whole run
        t_check = float(t_check)
        if not (math.isfinite(t_check) and dt <= t_check):
            raise ValueError(f"--t-check must be a number >= solver.dt ({dt} s), got {t_check!r}")
        t_end = min(t_end, t_check)
    fine_cfg = config_from_run(run_ds, {"solver.dt": dt / 2.0, "solver.t_end": t_end})
    base = run_ds.isel(time=np.flatnonzero(run_ds["time"].values <= t_end + 0.5 * dt))
    fine_run = simcore.run(fine_cfg)
    coarse = extract_impacts(base, **extract_kwargs)
    fine = extract_impacts(fine_run, **extract_kwargs)
    flagged, matches = compare_impacts(coarse, fine, n=n, tol=tol)
    flagged.attrs["dt_check_t_end"] = t_end
    return flagged, matches, fine_run


def _pct(x):
    return "   n/a" if not np.isfinite(x) else f"{100 * x:+6.1f}"


def format_dt_check(flagged: xr.Dataset, matches) -> str:
    """Text table of a dt-check."""
    a = flagged.attrs
    t_end = a.get("dt_check_t_end", float("nan"))
    lines = [f"dt-check: dt = {a['h']:g} s against {a['dt_check_h_fine']:g} s, first "
             f"{t_end:g} s, tolerance {100 * a['dt_check_tol']:g} %",
             f"{'contact':>7} {'ball':>4} {'race':>5} {'kind':>10} {'time [ms]':>9} "
             f"{'impulse [N s]':>16} {'d%':>6} {'v_pre [m/s]':>15} {'d%':>6} "
             f"{'F_max [N]':>17} {'d%':>6}  status"]
    for m in matches:
        if m["match"] is None:
            lines.append(f"{m['contact']:>7} {m['ball']:>4} {m['race']:>5} {m['kind']:>10} "
                         f"{1e3 * m['time']:>9.3f}   no matching impact at dt/2  FLAGGED")
            continue
        lines.append(
            f"{m['contact']:>7} {m['ball']:>4} {m['race']:>5} {m['kind']:>10} "
            f"{1e3 * m['time']:>9.3f} {m['impulse']:>7.4g}->{m['impulse_fine']:<8.4g}"
            f"{_pct(m['impulse_rel'])} {m['v_pre']:>6.4g}->{m['v_pre_fine']:<8.4g}"
            f"{_pct(m['v_pre_rel'])} {m['F_max']:>8.4g}->{m['F_max_fine']:<8.4g}"
            f"{_pct(m['F_max_rel'])}  {'FLAGGED' if m['moved'] else 'ok'}")
    n_bad = sum(m["moved"] for m in matches)
    lines.append(f"{n_bad} of {len(matches)} impacts moved by more than the tolerance "
                 "(flag not_converged_dt)")
    return "\n".join(lines)
