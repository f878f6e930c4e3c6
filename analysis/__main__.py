"""Command line of the analysis package: the paper's impulse filter, the Flores forces of
a nonsmooth run's impacts, the contact episodes of a compliant run, their dt check and
figures, and the study summary's figures (docs/forces.md, docs/study.md).

    python -m analysis impacts RUN.nc --out IMPACTS.nc [--zero-tol 1e-4] [--r-eff concave]
    python -m analysis filter RUN.nc --out FILTERED.nc
    python -m analysis top-forces RUN.nc [-n 3]
    python -m analysis dt-check RUN.nc [--t-check T] [--tol 0.1] [-n 6] [--out IMPACTS.nc]
    python -m analysis figures RUN.nc --outdir DIR [--impacts IMPACTS.nc] [--prefix NAME]
    python -m analysis study-figures SUMMARY.nc [--outdir DIR] [--axes X Y ...] [--fixed AXIS=V ...]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

PAPER_TOP3_KN = (3.66, 5.22, 4.69)


RUN_HELP = "a run file (python -m simcore run, a study's results/runs*/)"
R_EFF_HELP = ("effective radius of a ball in the outer race: concave (r_B r_C / (r_C - r_B), "
              "default) or paper (the convex form the paper used there); docs/forces.md")


def _filter_thresholds(p):
    p.add_argument("--zero-tol", type=float, default=1e-4,
                   help="relative zero threshold of the filter [-] (default 1e-4)")
    p.add_argument("--zero-floor", type=float, default=1e-12,
                   help="absolute floor of the zero threshold [N s] (default 1e-12)")


def _common(p):
    _filter_thresholds(p)
    p.add_argument("--v-min", type=float, default=1e-3,
                   help="smallest approach speed for a Flores force [m/s] (default 1e-3)")
    p.add_argument("--groove-conformity", type=float, default=None,
                   help="race groove radius / ball diameter (e.g. 0.52): elliptical "
                        "Hertz contacts of both races (default: the run's own "
                        "contacts, model.contact_geometry)")
    p.add_argument("--contact-long-ratio", type=float, default=10.0,
                   help="flag contact_long where the Hertz contact time exceeds this many "
                        "steps (default 10)")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``python -m analysis``."""
    ap = argparse.ArgumentParser(prog="python -m analysis", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    p = sub.add_parser("impacts", help="write the impact table of a run (of a compliant run or "
                                       "zoom: its contact episodes)")
    p.add_argument("run", help=RUN_HELP)
    p.add_argument("--out", required=True, help="the impact table to write (netCDF)")
    p.add_argument("--r-eff", choices=("concave", "paper"), default="concave", help=R_EFF_HELP)
    _common(p)
    p = sub.add_parser("filter", help="write Lambda_FI, Lambda_S, Lambda_FIsuv of a run")
    p.add_argument("run", help=RUN_HELP)
    p.add_argument("--out", required=True, help="the filtered impulses to write (netCDF)")
    _filter_thresholds(p)
    p = sub.add_parser("top-forces",
                       help="print the largest F_max on a race (--race) for both R_eff forms")
    p.add_argument("run", help=RUN_HELP)
    p.add_argument("-n", type=int, default=3, help="how many of the largest forces (default 3)")
    p.add_argument("--race", choices=("outer", "inner", "all"), default="outer",
                   help="the contacts ranked (default outer)")
    p.add_argument("--every-row", action="store_true",
                   help="rank the impact table's rows, not events (by default the rows of one "
                        "stretch of load on one contact count once, with their largest force)")
    _common(p)
    p = sub.add_parser("dt-check", help="rerun at dt/2 and compare the largest impacts")
    p.add_argument("run", help=RUN_HELP)
    p.add_argument("--t-check", type=float, default=None,
                   help="compare only the first T seconds (the rerun stops there)")
    p.add_argument("--tol", type=float, default=0.1,
                   help="relative change above which an impact is flagged (default 0.1)")
    p.add_argument("-n", type=int, default=6, help="how many of the largest impacts (default 6)")
    p.add_argument("--out", default=None,
                   help="write the impact table of the run with the dt-check flags")
    p.add_argument("--r-eff", choices=("concave", "paper"), default="concave", help=R_EFF_HELP)
    _common(p)
    p = sub.add_parser("figures", help="figures of one run")
    p.add_argument("run", help=RUN_HELP)
    p.add_argument("--outdir", required=True, help="the folder of the figures (created)")
    p.add_argument("--impacts", default=None,
                   help="impact table of RUN (python -m analysis impacts; computed if not given)")
    p.add_argument("--prefix", default=None,
                   help="file name prefix of the figures (default: from the run's parameters)")
    p.add_argument("--r-eff", choices=("concave", "paper"), default="concave", help=R_EFF_HELP)
    _common(p)
    p = sub.add_parser("study-figures",
                       help="figures of the study summary (every grid point) and its table")
    p.add_argument("summary", help="a study's summary (results/summary.nc)")
    p.add_argument("--outdir", default=None,
                   help="output folder (default: figures/ next to SUMMARY.nc)")
    # "extend": an option given twice adds to the first (the default "store" keeps the last)
    p.add_argument("--axes", nargs="+", action="extend", default=None, metavar="AXIS",
                   help="x, y (and panel columns, rows) of the heat maps (default: the first "
                        "swept axes)")
    p.add_argument("--fixed", nargs="+", action="extend", default=[], metavar="AXIS=VALUE",
                   help="hold other swept axes at a grid value, each axis once (default: the "
                        "study's reference point, as the study's figures; the middle value for "
                        "a summary that does not name one)")
    return ap


def format_top_forces(run_ds, n=3, race="outer", zero_tol=1e-4, zero_floor=1e-12,
                      v_min=1e-3, groove_conformity=None, contact_long_ratio=10.0,
                      every_row=False) -> str:
    """Text table of the ``n`` largest peak forces for r_eff = concave and r_eff = paper.

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run.
    n : int
        How many forces.
    race : {"outer", "inner", "all"}
        Contacts to consider.
    zero_tol, zero_floor, v_min, groove_conformity, contact_long_ratio
        Filter and force settings (see :func:`analysis.extract_impacts`).
    every_row : bool
        Rank rows of the impact table, not events: without it, the rows of one stretch of
        load on one contact (:func:`analysis.impacts.loaded_stretches`, a persistent contact)
        count once, with their largest force.

    Returns
    -------
    str
    """
    from .figures import run_label
    from .impacts import (
        RACE,
        extract_impacts,
        kind_name,
        loaded_stretches,
        race_name,
        top_forces,
    )

    lines = [f"run: {run_label(run_ds)}"]
    for r_eff in ("concave", "paper"):
        imp = extract_impacts(run_ds, zero_tol, zero_floor, r_eff=r_eff, v_min=v_min,
                              groove_conformity=groove_conformity,
                              contact_long_ratio=contact_long_ratio)
        top = top_forces(imp, n=n, race=None if race == "all" else race,
                         events=None if every_row else loaded_stretches(run_ds, imp))
        a = imp.attrs
        lines.append(
            f"\nr_eff = {r_eff}: K_outer = {a['K_outer']:.4g} N/m^1.5, K_pinch = "
            f"{a['K_pinch']:.4g} N/m^1.5, zero threshold = {a['zero_threshold']:.3g} N s "
            f"(zero_tol {a['zero_tol']:g}), impacts: {a['n_simple']} simple, "
            f"{a['n_persistent']} persistent (filter), of which {a['n_pinch']} pinch, "
            f"{a['n_multi']} multi; {a['n_no_approach']} without approach, {a['n_flagged']} "
            f"flagged; velocities from {a['v_pre_source'].split(':')[0]}")
        lines.append(f"{'rank':>4} {'F_max [kN]':>10} {'p_max [MPa]':>11} {'contact':>7} "
                     f"{'ball':>4} {'race':>5} {'time [s]':>9} {'kind':>10} "
                     f"{'impulse [N s]':>13} {'v_pre [m/s]':>11} {'m_eff [kg]':>10} "
                     f"{'F_static [N]':>12} {'t_c/dt':>7} {'flags':>5}")
        for i in range(top.sizes["impact"]):
            row = top.isel(impact=i)
            lines.append(
                f"{i + 1:>4} {float(row.F_max) / 1e3:>10.4g} {float(row.p_max) / 1e6:>11.4g} "
                f"{int(row.contact):>7} {int(row.ball):>4} {race_name(row.race):>5} "
                f"{float(row.time):>9.5f} {kind_name(row.kind):>10} "
                f"{float(row.impulse):>13.4g} {float(row.v_pre):>11.4g} "
                f"{float(row.m_eff):>10.4g} {float(row.F_static):>12.4g} "
                f"{float(row.contact_time_steps):>7.1f} {int(row.flags):>5}")
        if top.sizes["impact"] == 0:
            lines.append("   (no impact with a force)")
        # the paper's way: the three largest impulses on the one outer contact carrying the
        # largest impulse, whatever their force
        outer = (imp.where(imp["race"] == RACE["outer"], drop=True) if imp.sizes["impact"]
                 else imp)
        if outer.sizes["impact"]:
            c = int(outer["contact"].values[int(np.argmax(outer["impulse"].values))])
            one = imp.isel(impact=np.flatnonzero(imp["contact"].values == c))
            order = np.argsort(-one["impulse"].values, kind="stable")[:n]
            forces = ", ".join(_paper_style_force(one.isel(impact=k)) for k in
                               sorted(order, key=lambda k: one["time"].values[k]))
            lines.append(f"     paper-style, {n} largest impulses on contact {c} in time order: "
                         f"{forces}")
    lines.append("\npaper (Fig. 7d, one ball-outer-race contact, printed R_eff): "
                 + ", ".join(f"{v} kN" for v in PAPER_TOP3_KN))
    return "\n".join(lines)


def _paper_style_force(row) -> str:
    """One impact of the paper's way: its peak force and time, or, where it has no Flores
    force (the largest impulses of a loaded contact often carry no approach), why."""
    from .impacts import flag_names

    t = f"t = {float(row.time):.4f} s"
    if np.isfinite(float(row.F_max)):
        return f"{float(row.F_max) / 1e3:.4g} kN ({t})"
    return f"no force ({flag_names(row.flags) or 'static load only'}, {t})"


#: the numeric options and what each allows: (test, allowed in words)
_NUMBERS = {
    "zero_tol": (lambda x: 0.0 <= x < 1.0, "a number in [0, 1)"),
    "zero_floor": (lambda x: x >= 0.0, "a number >= 0 [N s]"),
    "v_min": (lambda x: x > 0.0, "a speed > 0 [m/s]"),
    "groove_conformity": (lambda x: x > 0.5, "a number > 0.5 (groove radius over ball "
                                             "diameter), or leave it out"),
    "contact_long_ratio": (lambda x: x > 0.0, "a number > 0"),
    "tol": (lambda x: x > 0.0, "a number > 0"),
    "t_check": (lambda x: x > 0.0, "a time > 0 [s]"),
    "n": (lambda x: x >= 1, "an integer >= 1"),
}


#: what every impact table holds (:func:`analysis.extract_impacts`; a study's table and the
#: flagged table of ``dt-check`` add columns): its columns on dimension ``impact``, and the
#: filter's threshold the table was made with
TABLE_COLUMNS = ("contact", "ball", "race", "time", "kind", "impulse", "F_max")
TABLE_ATTRIBUTES = ("zero_threshold",)
#: the longest figure name ``figures`` writes after its prefix
FIGURE_SUFFIX = "_slider.png"
_MAKE_TABLE = "allowed: the impact table of RUN (python -m analysis impacts RUN --out IMPACTS.nc)"


def check_impacts(path: str, run: str) -> str | None:
    """Why ``path`` cannot be given as the impact table of the run file ``run`` (``figures
    --impacts``; one line), or None: it must be an impact table (:data:`TABLE_COLUMNS`,
    :data:`TABLE_ATTRIBUTES`) whose records of its run (the run's title, the parameters
    clearance, mu, omega0, e_N, the step) match the run, with its impacts inside the run's
    time span. The path a table records (``run_file``) may have moved since, so it is not
    compared: a table of another run with the same settings and a longer span passes if its
    impacts lie within this run's. A run that cannot be read is not compared (the command
    reports it)."""
    import xarray as xr

    from simcore.io import load_netcdf

    from .impacts import STUDY_PARAMETERS
    from .reads import run_setting

    try:
        table = load_netcdf(path, "--impacts")
    except ValueError as exc:
        return f"{exc}; {_MAKE_TABLE}"
    if "impact" not in table.dims:
        return f"--impacts: {path} is not an impact table (no dimension impact); {_MAKE_TABLE}"
    lacks = [name for name in TABLE_COLUMNS
             if name not in table or table[name].dims != ("impact",)]
    lacks += [f"attribute {name}" for name in TABLE_ATTRIBUTES if name not in table.attrs]
    if lacks:
        return (f"--impacts: {path} is not an impact table (it lacks {', '.join(lacks)}); "
                f"{_MAKE_TABLE}")
    try:
        with xr.open_dataset(run) as run_ds:
            t = np.asarray(run_ds["time"].values, dtype=float)
            records = {"title": (table.attrs.get("run_title"), run_ds.attrs.get("title"))}
            for name in STUDY_PARAMETERS:
                ours = run_setting(run_ds, name, None)
                if name in table.coords and ours is not None:
                    records[name] = (float(table[name]), float(ours))
            # the interval of the run's impulses (analysis.impacts: the output interval, else
            # the solver's step)
            step = run_ds.attrs.get("output_interval_s", run_ds.attrs.get("solver.dt"))
            if "h" in table.attrs and step is not None:
                records["step"] = (float(table.attrs["h"]), float(step))
    except (OSError, ValueError, KeyError):
        return None
    for name, (theirs, ours) in records.items():
        if theirs is None or ours is None:
            continue
        same = (theirs == ours if isinstance(theirs, str)
                else np.isclose(theirs, ours, rtol=1e-9, atol=0.0))
        if not same:
            return (f"--impacts: {path} is the table of another run (its {name} {theirs!r}, "
                    f"RUN's {ours!r}); {_MAKE_TABLE}")
    times = np.asarray(table["time"].values, dtype=float)
    if t.size and times.size and (times.min() < t[0] or times.max() > t[-1]):
        return (f"--impacts: {path} is the table of another run (impacts at {times.min():.6g} "
                f"to {times.max():.6g} s, RUN spans {t[0]:.6g} to {t[-1]:.6g} s); {_MAKE_TABLE}")
    return None


def check_prefix(prefix: str, outdir: str) -> str | None:
    """Why ``prefix`` cannot begin the names of the figures of ``figures`` in ``outdir`` (one
    line), or None: a name, no path (its folder is ``--outdir``), short enough for the file
    system."""
    import os
    from pathlib import Path

    from simcore.cli import name_problem

    separators = sorted({sep for sep in (os.sep, os.altsep, "/") if sep})
    if any(sep in prefix for sep in separators):
        return (f"--prefix: {prefix!r} is not allowed; allowed: a file name prefix without "
                f"{' or '.join(map(repr, separators))} (the figures go into --outdir)")
    return name_problem(Path(outdir) / f"{prefix}{FIGURE_SUFFIX}", "--prefix", 0)


def check_args(args) -> str | None:
    """Why the arguments of ``python -m analysis`` cannot be used (one line), or None: every
    number, output file (the same rules as ``python -m simcore run --out``, not the input RUN),
    output folder, figure name prefix and given impact table, before any work."""
    from simcore.cli import check_out, check_outdir

    for name, (ok, allowed) in _NUMBERS.items():
        value = getattr(args, name, None)
        if value is not None and not (np.isfinite(value) and ok(value)):
            option = "-n" if name == "n" else "--" + name.replace("_", "-")
            return f"{option}: {value!r} is not allowed; allowed: {allowed}"
    if getattr(args, "out", None) is not None:
        problem = check_out(args.out, inputs={"RUN": getattr(args, "run", None)})
        if problem:
            return problem
    if getattr(args, "outdir", None) is not None:
        problem = check_outdir(args.outdir)
        if problem:
            return problem
    if getattr(args, "prefix", None):
        problem = check_prefix(args.prefix, args.outdir)
        if problem:
            return problem
    if getattr(args, "impacts", None) is not None:
        return check_impacts(args.impacts, args.run)
    return None


def _study_figures(args) -> int:
    """``study-figures``: the study's heat maps and its table from a summary file."""
    from pathlib import Path

    from simcore.io import load_netcdf
    from simcore.study.plan import FIGURE_OPTIONS

    from .figures import figure_layout, plot_study, stored_reference
    from .summary import summary_table

    outdir = Path(args.outdir or Path(args.summary).parent / "figures")
    fixed = {}
    for item in args.fixed:
        axis, _, value = item.partition("=")
        if not axis or not value:
            print(f"error: --fixed: {item!r} is not allowed; allowed: AXIS=VALUE (a number, "
                  "or the name of a category such as bearing=6205)", file=sys.stderr)
            return 2
        if axis in fixed:
            print(f"error: --fixed: {axis} given twice ({axis}={fixed[axis]}, {item}) is not "
                  "allowed; allowed: one value per axis", file=sys.stderr)
            return 2
        fixed[axis] = value  # a number or a category's name (analysis.figures.figure_layout)
    try:
        summary = load_netcdf(args.summary, "SUMMARY")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if not ("model" in summary.dims and "peak_force" in summary):
        print(f"error: SUMMARY: {args.summary} is not a study's summary (it has no model "
              "dimension and peak_force); allowed: the summary.nc a study writes",
              file=sys.stderr)
        return 2
    reference = stored_reference(summary)
    # the layout first: a bad one leaves no folder behind
    figure_layout(summary, args.axes, fixed, reference, FIGURE_OPTIONS)
    figures = plot_study(summary, outdir, figure_axes=args.axes, figure_fixed=fixed,
                         reference=reference, names=FIGURE_OPTIONS)
    for p in figures:
        print(p)
    table = summary_table(summary)
    table.to_csv(outdir / "summary_table.csv", index=False)
    print(outdir / "summary_table.csv")
    print(table.to_string(index=False))
    return 0


#: The options of the impulse filter and the Flores forces, which a compliant run's episodes
#: do not use.
FILTER_OPTIONS = ("zero_tol", "zero_floor", "v_min", "contact_long_ratio")
#: The commands of the paper's method, which reads a nonsmooth run's impulses.
NONSMOOTH_COMMANDS = ("filter", "top-forces", "dt-check", "figures")


def _is_compliant(run_ds) -> bool:
    from .summary import COMPLIANT, run_model

    return run_model(run_ds) == COMPLIANT


def _compliant_run(args, run_ds) -> int:
    """A compliant run (or zoom): ``impacts`` writes its contact episodes, as a study's table of
    a compliant twin holds them; the paper's method is refused (its contact forces are the
    run's own ``F_N``, not impulses to filter)."""
    defaults = vars(build_parser().parse_args(["impacts", "RUN", "--out", "OUT"]))
    for name in FILTER_OPTIONS:
        if args.command == "impacts" and getattr(args, name) != defaults[name]:
            option = "--" + name.replace("_", "-")
            print(f"error: {option}: not used on a compliant run ({args.run}: its episodes are "
                  f"its own forces, with no filter or Flores force); allowed: leave {option} "
                  "out", file=sys.stderr)
            return 2
    if args.command in NONSMOOTH_COMMANDS:
        print(f"error: RUN: {args.run} is a compliant run (model.contact_model = compliant), "
              f"whose contact forces F_N are in the file; allowed for {args.command}: a nonsmooth "
              "run (the paper's method reads its impulses); a compliant run's table: python -m "
              "analysis impacts", file=sys.stderr)
        return 2
    from simcore.io import write_netcdf

    from .episodes import contact_episodes

    table = contact_episodes(run_ds, args.r_eff, args.groove_conformity)
    table.attrs["run_file"] = str(args.run)
    write_netcdf(table, args.out)
    largest = (f", the largest F_max {float(table['F_max'].max()):.4g} N" if table.sizes["impact"]
               else "")
    print(f"{args.out}: {table.attrs['n_episodes']} contact episodes of a compliant run "
          f"(peak force F_N of each stretch of contact{largest})")
    return 0


def main(argv=None) -> int:
    """Entry point; returns the exit status."""
    args = build_parser().parse_args(argv)
    problem = check_args(args)  # settings and outputs first, before any work
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    import xarray as xr

    from simcore.io import load_netcdf

    try:
        if args.command == "study-figures":
            return _study_figures(args)
        run_ds = load_netcdf(args.run, "RUN")
        if "impact" in run_ds.dims:
            print(f"error: RUN: {args.run} is an impact table (dimension impact); allowed: a run "
                  "file, of which python -m analysis impacts makes the table", file=sys.stderr)
            return 2
        if int(run_ds.attrs.get("failed", 0)):
            print(f"error: RUN: {args.run} is the marker of a failed run (its error: "
                  f"{run_ds.attrs.get('error', 'not given')}); allowed: a file that holds a run",
                  file=sys.stderr)
            return 2
        if _is_compliant(run_ds):
            return _compliant_run(args, run_ds)
        if args.command == "impacts":
            from simcore.io import write_netcdf

            from .impacts import extract_impacts

            imp = extract_impacts(run_ds, args.zero_tol, args.zero_floor, args.r_eff, args.v_min,
                                  args.groove_conformity, args.contact_long_ratio)
            imp.attrs["run_file"] = str(args.run)
            write_netcdf(imp, args.out)
            a = imp.attrs
            print(f"{args.out}: {a['n_simple']} simple, {a['n_persistent']} persistent "
                  f"(filter; {a['n_pinch']} pinch, {a['n_multi']} multi), "
                  f"{a['n_no_approach']} without approach, {a['n_flagged']} flagged "
                  f"(zero threshold {a['zero_threshold']:.3g} N s)")
        elif args.command == "filter":
            from simcore.io import write_netcdf

            from .filtering import split_dataset

            write_netcdf(split_dataset(run_ds, args.zero_tol, args.zero_floor), args.out)
        elif args.command == "top-forces":
            print(format_top_forces(run_ds, args.n, args.race, args.zero_tol, args.zero_floor,
                                    args.v_min, args.groove_conformity,
                                    args.contact_long_ratio, args.every_row))
        elif args.command == "dt-check":
            from simcore.io import write_netcdf

            from .dt_check import dt_check, format_dt_check

            flagged, matches, _ = dt_check(
                run_ds, t_check=args.t_check, tol=args.tol, n=args.n, zero_tol=args.zero_tol,
                zero_floor=args.zero_floor, r_eff=args.r_eff, v_min=args.v_min,
                groove_conformity=args.groove_conformity,
                contact_long_ratio=args.contact_long_ratio)
            print(format_dt_check(flagged, matches))
            if args.out:
                flagged.attrs["run_file"] = str(args.run)
                write_netcdf(flagged, args.out)
        elif args.command == "figures":
            from .figures import plot_run
            from .impacts import extract_impacts

            if args.impacts:
                with xr.open_dataset(args.impacts) as d:
                    imp = d.load()
            else:
                imp = extract_impacts(run_ds, args.zero_tol, args.zero_floor, args.r_eff,
                                      args.v_min, args.groove_conformity,
                                      args.contact_long_ratio)
            for p in plot_run(run_ds, imp, args.outdir, args.zero_tol, args.zero_floor,
                              prefix=args.prefix):
                print(p)
    except (ValueError, KeyError, OSError) as exc:
        print(f"error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
