"""Command line: ``python -m simcore run [--config FILE] [--set KEY=VALUE ...] --out FILE.nc``."""

from __future__ import annotations

import argparse
import sys
import time


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m simcore",
                                description="Nonsmooth simulation of the SKF-6012 crank-slider.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="simulate one run and write its netCDF file")
    r.add_argument("--config", help="YAML configuration (default: the paper's case)")
    r.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override one key, e.g. --set model.mu=0 --set solver.t_end=0.05")
    r.add_argument("--out", required=True, help="output netCDF file")
    r.add_argument("--threads", type=int, default=None, help="Numba threads (default: all)")
    r.add_argument("--quiet", action="store_true", help="print nothing but errors")
    return p


def summary_lines(ds) -> list[str]:
    """What a run prints: wall time, Newton iterations against the paper's, largest impulse."""
    import numpy as np

    it = ds["iterations"].values[1:]
    lam = ds["Lambda_N"]
    k = np.unravel_index(int(np.argmax(lam.values)), lam.shape)
    paper_max = {"smooth": 3, "position": 23, "velocity": 5}
    paper_mean = {"smooth": 2, "position": 5, "velocity": 2}
    lines = [
        f"steps: {it.shape[0]}  dt = {ds.attrs['solver.dt']} s  t_end = {float(ds.time[-1]):.4g} s",
        f"wall time (integration): {ds.attrs['wall_time_s']:.3f} s",
        "Newton iterations per step   max  mean   (paper: max / mean)",
    ]
    for j, stage in enumerate(ds["stage"].values):
        lines.append(f"  {stage:<10}                 {it[:, j].max():4d}  {it[:, j].mean():4.2f}"
                     f"   ({paper_max[stage]} / {paper_mean[stage]})")
    lines.append(f"unconverged steps: {int((ds['converged'].values[1:] == 0).sum())}"
                 " (a step creating energy counts as unconverged)")
    if "energy_max_gain_J" in ds.attrs:
        lines.append(f"energy audit: largest gain of a step {ds.attrs['energy_max_gain_J']:.3g} J "
                     f"({ds.attrs['energy_max_gain_relative']:.2g} of the energy scale; "
                     f"solver.energy_tol = {ds.attrs['energy_tol']:g}), balance "
                     f"E_end - E_0 - drive work = {ds.attrs['energy_balance_J']:.4g} J")
    lines.append(f"largest Lambda_N: {lam.values[k]:.4g} N s at t = {float(ds.time[k[0]]):.4g} s, "
                 f"contact {int(ds.contact[k[1]])} (ball {int(ds.ball[k[1]])}, "
                 f"{ds.race.values[k[1]]} race)")
    lines.append(f"min gap_N: {float(ds['gap_N'].min()):.3g} m")
    return lines


def check_out(out: str) -> str | None:
    """Why ``--out`` cannot be written (one line), or None: checked before the simulation."""
    import os
    from pathlib import Path

    path = Path(out)
    if path.is_dir():
        return f"--out: {out} is a directory; allowed: a file name ending in .nc"
    if path.suffix != ".nc":
        return f"--out: {out} is not allowed; allowed: a file name ending in .nc"
    if path.exists() and not path.is_file():
        return f"--out: {out} exists and is not a regular file"
    folder = path.resolve().parent
    if not folder.is_dir():
        return f"--out: folder {folder} does not exist"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"--out: folder {folder} is not writable"
    # root passes os.access everywhere: try what the writer will do, create a file there
    import tempfile

    try:
        fd, probe = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".probe", dir=folder)
    except OSError as exc:
        return f"--out: folder {folder} is not writable ({exc.strerror})"
    os.close(fd)
    os.unlink(probe)
    return None


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    return f"warning: {message}\n"


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    import warnings

    from .config import ConfigError, load_config
    from .limits import check_memory_of_config, check_run_of_config

    warnings.formatwarning = _one_line_warning
    try:
        cfg = load_config(args.config, args.overrides)
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
    problem = check_out(args.out)
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
    from .io import write_netcdf
    from .model import SolverError
    from .simulate import run

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
    try:
        write_netcdf(ds, args.out)
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
