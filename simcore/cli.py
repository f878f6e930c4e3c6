"""Command line:

- ``python -m simcore run [--config FILE] [--set KEY=VALUE ...] --out FILE.nc`` (the file holds
  the variables of ``study.keep``; the printed summary is made before they are dropped)
- ``python -m simcore zoom RUN.nc --time T [--window W] [--dt H] [--set KEY=VALUE] --out Z.nc``
- ``python -m simcore bearings`` (the bearing catalogue: what each entry gives the model)
"""

from __future__ import annotations

import argparse
import sys
import time

#: what ``run --help`` shows (each runs: tests/test_cli.py)
RUN_EXAMPLES = (
    "python -m simcore run --out paper.nc",
    "python -m simcore run --set model.contact_model=compliant --set model.youngs_modulus=2.1e11"
    " --set solver.adaptive=true --set solver.dt=1e-5 --out hertz.nc",
    "python -m simcore run --set model.bearing=6205 --set model.clearance_class=C3 --out 6205.nc",
)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m simcore",
        description="Simulate a ball bearing in a crank-slider, with the paper's nonsmooth "
                    "contacts or compliant (Hertz) ones; the paper's SKF 6012 case by default.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser(
        "run", help="simulate one run and write its netCDF file",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n" + "".join(f"  {line}\n" for line in RUN_EXAMPLES)
               + "every key, its unit and allowed values: "
                 "simcore/config/schema/config.schema.json (a study's sweep and study keys: "
                 "config/README.md)")
    r.add_argument("--config", help="YAML configuration (default: the paper's case)")
    r.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override one key, e.g. --set model.mu=0 --set solver.t_end=0.05")
    r.add_argument("--out", required=True, help="output netCDF file")
    r.add_argument("--threads", type=int, default=None, help="Numba threads (default: all)")
    r.add_argument("--quiet", action="store_true", help="print nothing but errors")
    z = sub.add_parser("zoom", help="re-simulate a run around a time with compliant contacts")
    z.add_argument("run", help="netCDF file of a run (with its restart state)")
    z.add_argument("--time", type=float, required=True,
                   help="time of interest [s]; the zoom starts from the run's sample before it")
    z.add_argument("--window", type=float, default=2e-3,
                   help="longest zoom duration [s] (default: %(default)g)")
    z.add_argument("--dt", type=float, default=1e-6,
                   help="largest step of the zoom and its output interval [s] (default: "
                        "%(default)g; adaptive steps, a fixed step with --set "
                        "solver.adaptive=false)")
    z.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a setting of the zoom, e.g. --set model.youngs_modulus=2.1e11")
    z.add_argument("--out", required=True, help="output netCDF file")
    z.add_argument("--quiet", action="store_true", help="print nothing but errors")
    sub.add_parser("bearings", help="list the bearing catalogue (model.bearing): dimensions, "
                                    "ratings, balls, rings and each class's clearance")
    return p


def bearings_lines() -> list[str]:
    """The catalogue, one block per entry (``python -m simcore bearings``): dimensions and
    ratings as the entry gives them, the balls, rings and masses the model gets
    (:func:`simcore.model.bearing.model_geometry`), the share of the catalogue's bearing mass
    that rings and balls make, the groove conformities, and the model's clearance g of each ISO
    class for its bore."""
    from .model.bearing import CLEARANCE_CLASSES, catalogue, model_clearance, model_geometry

    lines = []
    for name, entry in catalogue().items():
        model = model_geometry(name)
        ratings = ("C {:g} kN, C0 {:g} kN".format(entry["C"] / 1e3, entry["C0"] / 1e3)
                   if entry.get("C") is not None else "no load ratings")
        lines.append(f"{name}: d x D x B = {entry['d']:g} x {entry['D']:g} x {entry['B']:g} mm, "
                     f"{model['n_balls']} balls of {2e3 * model['ball_radius']:.3f} mm "
                     f"({1e3 * model['ball_mass']:.2f} g), {ratings}")
        rings = [f"{race} ring {1e3 * model[f'{race}_mass']:.0f} g, "
                 f"{model[f'{race}_inertia']:.3g} kg m^2" for race in ("inner", "outer")
                 if f"{race}_mass" in model]
        weight = ""
        if entry.get("mass") is not None and len(rings) == 2:
            total = (model["inner_mass"] + model["outer_mass"]
                     + model["n_balls"] * model["ball_mass"])
            weight = (f"; rings and balls {100 * total / entry['mass']:.1f} % of its "
                      f"{entry['mass']:g} kg")
        grooves = (f"; grooves f_i {model['inner_conformity']:g}, f_e {model['outer_conformity']:g}"
                   if "inner_conformity" in model else "; no grooves given (the model's)")
        lines.append("  " + ("; ".join(rings) or "the model's race masses") + weight + grooves)
        classes = []
        for cls in CLEARANCE_CLASSES:
            try:
                classes.append(f"{cls} {1e6 * model_clearance(entry['d'], cls):.2f}")
            except ValueError:  # a class the table lacks for this bore
                continue
        lines.append("  clearance g [um] (half the ISO radial internal clearance): "
                     + ", ".join(classes))
    return lines


def summary_lines(ds) -> list[str]:
    """What a run prints: wall time, Newton iterations against the paper's, largest impulse."""
    import numpy as np

    it = ds["iterations"].values[1:]
    lam = ds["Lambda_N"]
    k = np.unravel_index(int(np.argmax(lam.values)), lam.shape)
    paper_max = {"smooth": 3, "position": 23, "velocity": 5}
    paper_mean = {"smooth": 2, "position": 5, "velocity": 2}
    lines = [*steps_lines(ds, it.shape[0]),
             f"wall time (integration): {ds.attrs['wall_time_s']:.3f} s",
             "Newton iterations per step   max  mean   (paper: max / mean)"]
    for j, stage in enumerate(ds["stage"].values):
        lines.append(f"  {stage:<10}                 {it[:, j].max():4d}  {it[:, j].mean():4.2f}"
                     f"   ({paper_max[stage]} / {paper_mean[stage]})")
    lines.append(f"unconverged steps: {int((ds['converged'].values[1:] == 0).sum())}"
                 " (a step creating energy or breaking an integrity check counts as unconverged)")
    if "n_retried_steps" in ds.attrs and not ds.attrs.get("solver.adaptive", 0):
        unit = ("output intervals with a retried step" if ds.attrs.get("contact_model")
                == "compliant" else "retried steps")
        lines.append(f"{unit} (taken again as substeps): {ds.attrs['n_retried_steps']}")
    if "energy_max_gain_J" in ds.attrs:
        window = ""
        if "energy_max_window_gain_J" in ds.attrs:
            window = (f", of steps together {ds.attrs['energy_max_window_gain_J']:.3g} J "
                      f"({ds.attrs['energy_max_window_gain_relative']:.2g})")
        lines.append(f"energy audit: largest gain of a step {ds.attrs['energy_max_gain_J']:.3g} J "
                     f"({ds.attrs['energy_max_gain_relative']:.2g} of the energy scale){window}; "
                     f"solver.energy_tol = {ds.attrs['energy_tol']:g}; balance "
                     f"E_end - E_0 - drive work = {ds.attrs['energy_balance_J']:.4g} J")
    lines.append(f"largest Lambda_N: {lam.values[k]:.4g} N s at t = {float(ds.time[k[0]]):.4g} s, "
                 f"contact {int(ds.contact[k[1]])} (ball {int(ds.ball[k[1]])}, "
                 f"{ds.race.values[k[1]]} race)")
    lines.append(f"min gap_N: {float(ds['gap_N'].min()):.3g} m")
    lines.append(bearing_line(ds))
    if "F_N" in ds:
        lines.append(largest_force_line(ds, "a longer solver.t_end"))
    return lines


def steps_lines(ds, rows: int) -> list[str]:
    """The steps of a run, its step size and length; of an adaptive run the steps it took and
    redid, the smallest step it took and the largest it allows (``solver.dt``), how its
    steps spread over the output intervals (variable ``steps``), and whether it was run again
    at a smaller tolerance (``n_tolerance_retries``)."""
    import numpy as np

    a = ds.attrs
    span = (f"t_end = {float(ds.time[-1]):.4g} s  ({a.get('contact_model', 'nonsmooth')} "
            f"contacts, {rows} output rows)")
    from .io import time_steps

    if "n_steps_accepted" not in a:
        return [f"steps: {time_steps(ds):.0f}  dt = {a['solver.dt']} s  {span}"]
    lines = [f"steps: {time_steps(ds):.0f} adaptive ({a['n_steps_rejected']} redone)  "
             f"dt = {a['dt_smallest_s']:.3g} to {a['solver.dt']} s  {span}"]
    retries = int(a.get("n_tolerance_retries", 0))
    if retries:
        lines.append(f"run again {retries} time(s) after the energy audit failed: "
                     f"solver.adaptive_tol {a['solver.adaptive_tol']:g} -> "
                     f"{a['adaptive_tol_used']:g} m")
    if "steps" in ds and rows:
        per_row = np.asarray(ds["steps"].values[1:])
        k = int(np.argmax(per_row))
        lines.append(f"steps per output interval: median {np.median(per_row):g}, largest "
                     f"{per_row[k]} (interval ending at t = {float(ds.time[k + 1]):.6g} s)")
    return lines


def largest_force_line(ds, longer: str) -> str:
    """The largest ``F_N`` of a compliant run, its time and contact, in one line; marked where
    it is the last sample and still rising, so that the true peak lies after the run (``longer``
    names the setting that would reach it)."""
    import numpy as np

    F = np.asarray(ds["F_N"].values, dtype=float)
    k = np.unravel_index(int(np.argmax(F)), F.shape)
    line = (f"largest F_N: {F[k]:.4g} N at t = {float(ds.time[k[0]]):.6g} s, contact "
            f"{int(ds.contact[k[1]])} (ball {int(ds.ball[k[1]])}, {ds.race.values[k[1]]} race)")
    if k[0] == F.shape[0] - 1 and F.shape[0] > 1 and F[k] > F[k[0] - 1, k[1]]:
        line += (f"; NOT the peak: the force still rises at the run's last sample (the peak "
                 f"comes later: {longer})")
    return line


def bearing_line(ds) -> str:
    """The bearing of a run, its guard contacts and its integrity checks, in one line."""
    a = ds.attrs
    clearance_class = a.get("model.clearance_class")
    g = a["model.clearance"]
    line = (f"bearing: {a.get('model.bearing', '?')}, clearance g {g:.4g} m (ISO radial "
            f"internal clearance 2g = {2e6 * g:.4g} um"
            + (f", class {clearance_class})" if clearance_class else ")"))
    if a.get("model.contact_geometry") == "groove":
        line += (f", balls in grooves (conformities {a['model.inner_conformity']:g} inner, "
                 f"{a['model.outer_conformity']:g} outer)")
    if "guard" in ds.coords:
        line += (f"; guard contacts closed on {a['guard_ball_ball_closed_samples']} samples "
                 f"(ball against ball), {a['guard_rings_closed_samples']} (the rings' lands)")
    else:
        line += "; no guard contacts (model.guard_contacts = false)"
    return line + f"; integrity checks: {a.get('integrity_violations', 'none')}"


#: the options of ``zoom`` by the parameter of :func:`simcore.study.zoom.zoom_config` each
#: sets (its output interval is its step, ``--dt``)
ZOOM_OPTIONS = {"window": "--window", "dt": "--dt", "output_dt": "--dt"}


def _zoom_main(args) -> int:
    from .config import ConfigError
    from .model import SolverError

    problem = check_out(args.out, inputs={"RUN": args.run})
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    try:
        check_sweep({}, args.overrides)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    from .io import load_netcdf

    try:
        run_ds = load_netcdf(args.run, "RUN")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    import warnings

    from .io import write_netcdf
    from .study.zoom import start_index, zoom, zoom_config

    try:  # every check before any work (its warnings are given once, by the zoom itself)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            zoom_config(run_ds, window=args.window, dt=args.dt, overrides=args.overrides,
                        names=ZOOM_OPTIONS)
        start_index(run_ds, args.time)
    except ConfigError as exc:
        # a message names the key; where an option of the command set it, the option (no
        # --set can set solver.t_end or solver.dt: zoom_config refuses it)
        prefixes = {"run": f"RUN: {args.run}", "time": "--time", "overrides": "--set",
                    "solver.t_end": ZOOM_OPTIONS["window"], "solver.dt": ZOOM_OPTIONS["dt"]}
        msg = str(exc)
        key = msg.split(":", 1)[0]
        if key in prefixes:
            msg = prefixes[key] + msg[len(key):]
        print(f"error: {msg}", file=sys.stderr)
        return 2
    start = time.perf_counter()
    try:
        ds = zoom(run_ds, args.time, window=args.window, dt=args.dt, overrides=args.overrides,
                  progress=not args.quiet)
    except SolverError as exc:
        print(f"error: {exc}; no output written", file=sys.stderr)
        return 3
    try:
        write_netcdf(ds, args.out)
    except OSError as exc:
        print(f"error: --out: cannot write {args.out}: {exc}", file=sys.stderr)
        return 4
    if not args.quiet:
        print(f"zoom from t = {ds.attrs['zoom_start_time']:.6g} s, {ds.sizes['time'] - 1} "
              f"samples of {ds.attrs['solver.output_dt']:.3g} s")
        print(largest_force_line(ds, "a longer --window"))
        print(f"wall time: {time.perf_counter() - start:.2f} s")
        print(f"written: {args.out}")
    return 0


#: characters the atomic writer adds to a file name for its temporary file (``.NAME.`` +
#: eight random characters + ``.tmp``) and the check below for its probe (``.probe``)
TEMP_NAME_EXTRA = 16


def _name_max(folder) -> int:
    """Longest file name [bytes] in ``folder`` (its file system's NAME_MAX; 255 when unknown)."""
    import os

    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


def _writable_folder(folder, option: str) -> str | None:
    """Why no file can be created in the existing ``folder`` (one line), or None."""
    import os
    import tempfile

    if not os.access(folder, os.W_OK | os.X_OK):
        return f"{option}: folder {folder} is not writable"
    # root passes os.access everywhere: try what the writer will do, create a file there
    try:
        fd, probe = tempfile.mkstemp(prefix=".", suffix=".probe", dir=folder)
    except OSError as exc:
        return f"{option}: folder {folder} is not writable ({exc.strerror})"
    os.close(fd)
    os.unlink(probe)
    return None


def name_problem(path, option: str, extra: int) -> str | None:
    """Why the names of ``path`` are too long for its file system (one line), or None.

    Shared by the output checks of ``python -m simcore`` and ``python -m analysis``.

    Parameters
    ----------
    path : pathlib.Path
        The file to be written.
    option : str
        The option that gave it, named in the message (``--out``, ``--prefix``).
    extra : int
        Characters a writer adds to the file's name (the atomic writer's temporary name:
        :data:`TEMP_NAME_EXTRA`; 0 for a name written as it is).
    """
    import os

    try:
        name_max = _name_max(path.parent if path.parent.is_dir() else ".")
    except OSError:  # the folder's own name is too long to look at
        name_max = _name_max(".")
    for i, part in enumerate(path.parts):
        size = len(os.fsencode(part))
        limit = name_max - (extra if i == len(path.parts) - 1 else 0)
        if size > limit:
            return (f"{option}: a name of {size} bytes ({part[:24]}...) is not allowed; "
                    f"allowed: at most {limit} bytes (the file system's limit"
                    + (f", less {extra} for the temporary file written first)"
                       if limit < name_max else ")"))
    if len(os.fsencode(str(path.resolve()))) > 4000:
        return f"{option}: a path of more than 4000 bytes is not allowed"
    return None


def _same_file(a: str, b: str) -> bool:
    """Whether the paths ``a`` and ``b`` both exist and are one file (a link, another
    spelling of its path)."""
    import os

    try:
        return os.path.exists(a) and os.path.exists(b) and os.path.samefile(a, b)
    except OSError:
        return False


def check_out(out: str, option: str = "--out", suffix: str = ".nc",
              inputs: dict[str, str | None] | None = None) -> str | None:
    """Why ``out`` cannot be written as a result file (one line), or None: checked before any
    work, the same rules for every command (``python -m simcore run|zoom``, ``python -m
    analysis``): a name ending in ``suffix``, not a directory, not one of the command's input
    files, short enough for the file system with the temporary name of the atomic writer, in
    an existing writable folder.

    Parameters
    ----------
    out : str
        The path given.
    option : str
        The option's name in the message.
    suffix : str
        Required file name ending.
    inputs : dict, optional
        The command's input files, {name in the message (``RUN``, ``--config``): path or None}.
    """
    from pathlib import Path

    path = Path(out)
    problem = name_problem(path, option, TEMP_NAME_EXTRA)
    if problem:
        return problem
    try:
        if path.is_dir():
            return f"{option}: {out} is a directory; allowed: a file name ending in {suffix}"
        if path.suffix != suffix:
            return f"{option}: {out} is not allowed; allowed: a file name ending in {suffix}"
        if path.exists() and not path.is_file():
            return f"{option}: {out} exists and is not a regular file"
        for name, given in (inputs or {}).items():
            # the writer replaces the file, and the input with it (any spelling of its path)
            if given is not None and _same_file(out, given):
                return f"{option}: {out} is the input {name}; allowed: another file"
        folder = path.resolve().parent
        if not folder.is_dir():
            return f"{option}: folder {folder} does not exist"
    except OSError as exc:
        return f"{option}: {out} cannot be used ({exc.strerror})"
    return _writable_folder(folder, option)


def check_outdir(outdir: str, option: str = "--outdir") -> str | None:
    """Why files cannot be written into the folder ``outdir`` (one line), or None: it is a
    writable directory, or it does not exist and its nearest existing parent is one (the
    command creates it); names short enough for the file system."""
    from pathlib import Path

    path = Path(outdir)
    problem = name_problem(path, option, 0)
    if problem:
        return problem
    try:
        if path.exists() and not path.is_dir():
            return f"{option}: {outdir} exists and is not a directory; allowed: a folder"
        existing = path.resolve()
        while not existing.exists():
            existing = existing.parent
        if not existing.is_dir():
            return f"{option}: {existing} is not a directory"
    except OSError as exc:
        return f"{option}: {outdir} cannot be used ({exc.strerror})"
    return _writable_folder(existing, option)


#: the ``study`` settings one run reads (the variables its file keeps)
RUN_STUDY_SETTINGS = ("keep",)


def check_sweep(cfg, overrides) -> None:
    """The sweep of a configuration in ``python -m simcore run``, which makes one run at the
    ``model``, ``solver`` and ``analysis`` settings: one given with ``--set`` is refused (a
    sweep was meant); one in a ``--config`` file (a study's file, run once) is warned of,
    naming the values the run takes instead. The ``study`` settings that differ from the
    schema's defaults (but :data:`RUN_STUDY_SETTINGS`), from a file or ``--set``, are warned
    of once, naming them; with ``study.revolutions``, the warning gives the run's
    ``solver.t_end`` and the one the revolutions would give a study's run.

    Raises
    ------
    simcore.ConfigError
        For a sweep given with ``--set``: one line naming it and what is allowed.
    """
    import warnings

    from .config import ConfigError, load_schema
    from .config.parameters import parameter

    given = [item.split("=", 1)[0] for item in overrides if item.startswith("sweep")]
    if given:
        raise ConfigError(f"{given[0]}: a sweep is not allowed in one run; allowed: the run's "
                          "own values (--set model.KEY=VALUE); a study runs a sweep: snakemake "
                          "-j2 --configfile FILE")
    swept = [parameter(key) for key in cfg.get("sweep") or {}]
    if swept:
        values = ", ".join(f"{p.key} = {cfg[p.section][p.setting]}" for p in swept)
        warnings.warn(f"sweep: not read by one run (a study's: snakemake -j2 --configfile "
                      f"FILE); this run takes {values}", UserWarning, stacklevel=2)
    schema = load_schema()["properties"]["study"]["properties"]  # read once, not per key
    study = {key: value for key, value in (cfg.get("study") or {}).items()
             if key not in RUN_STUDY_SETTINGS and value != schema[key].get("default")}
    if study:
        values = ", ".join(f"study.{key} = {value}" for key, value in study.items())
        warnings.warn(f"study: not read by one run (a study's: snakemake -j2 --configfile "
                      f"FILE): {values}{_run_length_hint(cfg, study)}", UserWarning,
                      stacklevel=2)


def _run_length_hint(cfg, study) -> str:
    """What ends the warning of ``study`` settings where ``study.revolutions`` is among them:
    the run's own length, ``solver.t_end``, and the one a study's run of these settings
    would take from the revolutions (:func:`simcore.study.plan.run_length`)."""
    from .config import ConfigError
    from .study.plan import run_length

    if study.get("revolutions") is None:
        return ""
    hint = (f"; study.revolutions does not set this run's length, solver.t_end does (now "
            f"{cfg['solver']['t_end']:g} s")
    try:
        t_end = run_length(cfg)
    except ConfigError:  # omega0 = 0, or too long: the revolutions give no length
        return hint + ")"
    # (a study reads config/config.yaml beneath its file: its runs' settings may differ)
    return hint + (f"; {cfg['analysis']['settle']:g} + {study['revolutions']:g} revolutions of "
                   f"this run's settings, which lack the config/config.yaml a study reads "
                   f"beneath its FILE: --set solver.t_end={t_end:g})")


class _WarnOnce:
    """``warnings.showwarning`` of the command line: each warning as one line ``warning: ...``
    on standard error, once (a setting checked again by the run warns again, from the same
    line, once the filters were reset by a ``catch_warnings`` block in between)."""

    def __init__(self):
        self.shown = set()

    def __call__(self, message, category, filename, lineno, file=None, line=None):
        text = f"warning: {message}\n"
        if text not in self.shown:
            self.shown.add(text)
            (file or sys.stderr).write(text)


def main(argv=None) -> int:
    """The command line (module docstring); returns the exit code. Python's cyclic garbage
    collector is paused while it runs (a command loads much and frees little: start-up patch
    ``gc_freeze``, :func:`simcore.startup.patches.collector_paused`) and runs again
    afterwards; warnings are printed as one line each, once (:class:`_WarnOnce`)."""
    import warnings

    from .startup.patches import collector_paused

    with collector_paused(), warnings.catch_warnings():
        warnings.showwarning = _WarnOnce()
        return _main(argv)


def _main(argv=None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "zoom":
        return _zoom_main(args)
    if args.command == "bearings":
        print("\n".join(bearings_lines()))
        return 0
    import warnings

    from .config import ConfigError, load_config
    from .config.limits import check_memory_of_config, check_run_of_config

    try:
        cfg = load_config(args.config, args.overrides)
        check_sweep(cfg, args.overrides)
        check_memory_of_config(cfg)  # before any model or array is built
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.threads is not None:
        import numba

        if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
            print(f"error: --threads: {args.threads} is not allowed; allowed: an integer in "
                  f"[1, {numba.config.NUMBA_NUM_THREADS}]", file=sys.stderr)
            return 2
        numba.set_num_threads(args.threads)
    problem = check_out(args.out, inputs={"--config": args.config})
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    try:
        # step size from the configuration alone (run() checks it again on the built model)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            check_run_of_config(cfg)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    from .model import SolverError
    from .runner import run

    start = time.perf_counter()
    try:
        ds = run(cfg, progress=not args.quiet)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except SolverError as exc:
        print(f"error: {exc}; no output written", file=sys.stderr)
        return 3
    except MemoryError:
        print("error: out of memory during the run; lower solver.max_memory_gb below the "
              "machine's free memory, or shorten solver.t_end", file=sys.stderr)
        return 3
    from .io import write_netcdf

    try:
        write_netcdf(ds, args.out, keep=cfg["study"]["keep"])  # study.keep
    except OSError as exc:
        print(f"error: --out: cannot write {args.out}: {exc}", file=sys.stderr)
        return 4
    if not args.quiet:
        for line in summary_lines(ds):
            print(line)
        print(f"total wall time (build, compile or cache load, run, write): "
              f"{time.perf_counter() - start:.2f} s")
        print(f"written: {args.out}")
    return 0
