"""Where the paper's method agrees with its compliant twin, from a study's summary.

Prints, for ``method_ratio`` (the nonsmooth steady peak force over the compliant one, per race)
and for the same ratio of the medians over revolutions (``peak_force_rev_median``): how many
values lie within 1 +- analysis.method_tol, their range and median over the grid, by each swept
axis, and by the static deflection ratio (a ball's Hertz deflection under the largest steady
load over the clearance); then ``peak_force_flagged``, and from the nonsmooth impact tables the
zooms of the impacts that give ``peak_force``: how many give a verdict and how many of those
agree with F_max within the tolerance; how many of them are flagged ``peak_at_onset`` (a loaded
contact's Flores force at its start, F_s (1 + c), docs/forces.md §2), by e_N, and the steady
peak's ratio to the compliant one where such a row counts with its static force F_s instead.

    python benchmarks/method_ratio_report.py [results/summary.nc] [--impacts results/impacts]
"""

from __future__ import annotations

import argparse

import numpy as np
import xarray as xr

#: Bins of the static deflection ratio.
DEFLECTION_BINS = (0.0, 0.1, 0.3, 1.0, 3.0, np.inf)


def describe(values: np.ndarray, tol: float) -> str:
    """n, within tolerance, range and median of ratios."""
    v = values[np.isfinite(values)]
    if not v.size:
        return "no values"
    inside = int(np.sum(np.abs(v - 1.0) <= tol))
    return (f"{v.size} values, {inside} within {tol:g} ({100 * inside / v.size:.0f} %), "
            f"{v.min():.2f} to {v.max():.2f}, median {np.median(v):.2f}")


def report(summary: xr.Dataset) -> None:
    tol = float(summary.attrs.get("method_tol", 0.2))
    axes = [d for d in summary["failed"].dims if d != "model"]
    pf = summary["peak_force_rev_median"]
    ratios = {"steady peak (method_ratio)": summary["method_ratio"],
              "median over revolutions": pf.sel(model=0, drop=True)
              / pf.sel(model=1, drop=True).where(pf.sel(model=1, drop=True) > 0)}
    deflection = summary["static_deflection_ratio"]
    for name, ratio in ratios.items():
        print(f"\n### {name}: nonsmooth / compliant")
        print(f"all points, both races: {describe(ratio.values.ravel(), tol)}")
        for axis in axes:
            if summary.sizes[axis] < 2:
                continue
            for value in summary[axis].values:
                sel = ratio.sel({axis: value}).values.ravel()
                print(f"  {axis} = {float(value):g}: {describe(sel, tol)}")
        both = ratio.transpose(*axes, "race").values
        d = np.broadcast_to(deflection.transpose(*axes).values[..., None], both.shape)
        for lo, hi in zip(DEFLECTION_BINS[:-1], DEFLECTION_BINS[1:], strict=True):
            sel = both[(d >= lo) & (d < hi)]
            print(f"  static deflection ratio in [{lo:g}, {hi:g}): {describe(sel, tol)}")
    flagged = summary["peak_force_flagged"].values
    known = np.isfinite(flagged)
    print(f"\npeak_force_flagged: {int(np.sum(flagged[known] > 0))} of {int(known.sum())}")
    outside = np.abs(summary["method_ratio"].values - 1.0) > tol
    unflagged = outside & (flagged == 0)
    print(f"values outside the tolerance left unflagged: {int(unflagged.sum())}")


def zoom_report(folder: str, tol: float, summary: xr.Dataset) -> None:
    """The zooms of the impacts that give each table's steady peak force per race, and how
    many of those are a loaded contact's start (``peak_at_onset``)."""
    from collections import defaultdict
    from pathlib import Path

    from analysis.impacts import FLAG

    peaks = verdicts = disagree = loaded = 0
    ratios = []
    onset = defaultdict(int)     # e_N: peak-force impacts flagged peak_at_onset
    of_e = defaultdict(int)      # e_N: peak-force impacts
    static_ratio = defaultdict(list)  # e_N: steady peak with onset rows at F_s, over compliant
    for path in sorted(Path(folder).glob("*.nc")):
        with xr.open_dataset(path) as table:
            if "F_max_zoom" not in table:
                continue
            settle = table.attrs.get("zoom_settle_time", -np.inf)
            force = table["F_max"].values
            steady = (table["time"].values > settle) & np.isfinite(force)
            at_onset = (table["flags"].values & FLAG["peak_at_onset"]) > 0
            static = np.where(at_onset, table["F_static"].values, force)
            point = {name: float(table[name]) for name in ("clearance", "mu", "omega0", "e_N")
                     if name in summary.coords and name in table.coords}
            e_N = point.get("e_N", np.nan)
            for race in (0, 1):
                rows = np.flatnonzero(steady & (table["race"].values == race))
                if not rows.size:
                    continue
                row = rows[np.argmax(force[rows])]
                peaks += 1
                of_e[e_N] += 1
                onset[e_N] += bool(at_onset[row])
                twin = float(summary["peak_force"].sel(model=1, race=race, **point))
                static_ratio[e_N].append(np.max(static[rows]) / twin if twin > 0 else np.nan)
                if "zoom_loaded_start" in table:
                    loaded += int(table["zoom_loaded_start"].values[row])
                zoom = float(table["F_max_zoom"].values[row])
                if np.isfinite(zoom):
                    verdicts += 1
                    ratios.append(force[row] / zoom)
                    disagree += bool(int(table["flags"].values[row])
                                     & FLAG["method_disagrees"])
    print(f"\nimpacts that give peak_force: {peaks}; not zoomed, their ball loaded at the "
          f"zoom's start: {loaded}; zooms with a verdict: {verdicts} "
          f"(F_max / F_max_zoom {describe(np.asarray(ratios), tol)}); flagged "
          f"method_disagrees: {disagree}")
    print("of them flagged peak_at_onset (F_max = F_s (1 + c), the start of a loaded contact's "
          "force): " + ", ".join(f"{onset[e]} of {of_e[e]} at e_N = {e:g}" for e in sorted(of_e)))
    print("steady peak with such rows at F_s instead, over the compliant peak:")
    for e in sorted(static_ratio):
        print(f"  e_N = {e:g}: {describe(np.asarray(static_ratio[e]), tol)}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("summary", nargs="?", default="results/summary.nc")
    p.add_argument("--impacts", default=None, help="folder of the nonsmooth impact tables")
    args = p.parse_args(argv)
    with xr.open_dataset(args.summary) as summary:
        summary = summary.load()
    report(summary)
    if args.impacts:
        zoom_report(args.impacts, float(summary.attrs.get("method_tol", 0.2)), summary)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
