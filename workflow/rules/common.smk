# Shared helpers of the study workflow: configuration checks, the parameter grid, paths.
#
# Everything here runs when Snakemake parses the workflow, before any job starts: a bad
# configuration stops the study with one line naming the key.

import copy
import itertools
import logging
import math
import re
import sys
from contextlib import contextmanager
from pathlib import Path

import pandas as pd
from snakemake.exceptions import WorkflowError
from snakemake.utils import Paramspace, validate

import simcore
from simcore.config import SCHEMA_PATH

# The swept model keys, in the order of the file names and of the summary's dimensions.
SWEPT = ("clearance", "mu", "omega0", "e_N")

def tidy(value):
    """Round a parameter to 10 significant digits so that file names carry no float noise."""
    return float(f"{float(value):.10g}")


class _DropSchemaVersionWarning(logging.Filter):
    _TEXT = ("No validator found for JSON Schema", "Defaulting to validator for JSON Schema",
             "Note that schema file may not be validated")

    def filter(self, record):
        return not str(record.getMessage()).startswith(self._TEXT)


@contextmanager
def _quiet_schema_version():
    from snakemake.logging import logger

    muted = _DropSchemaVersionWarning()
    logger.addFilter(muted)
    try:
        yield
    finally:
        logger.removeFilter(muted)


def _checked_config(raw):
    """Validate the merged config (see _study_config); raise a one-line error naming the key."""
    cfg = dict(raw)
    try:
        full = simcore.validate_config(cfg)
    except simcore.ConfigError as exc:
        raise WorkflowError(f"invalid configuration: {exc}") from None
    # The same JSON schema again, through Snakemake's own validator (fills the same defaults).
    # Snakemake 9 validates with the draft 2020-12 rules, which read every keyword of our
    # draft-07 schema the same way; its three-line warning about the version is muted.
    with _quiet_schema_version():
        validate(full, str(SCHEMA_PATH))
    return full


def _grid(cfg):
    """Full-factorial grid of the sweep; axes that are not swept use the model value."""
    axes = {}
    for key in SWEPT:
        values = cfg["sweep"].get(key, [cfg["model"][key]])
        rounded = sorted({tidy(v) for v in values})
        if len(rounded) < len(values):
            raise WorkflowError(
                f"invalid configuration: sweep.{key}: {values!r} holds the same value twice "
                "(after rounding to 10 significant digits)")
        axes[key] = rounded
    frame = pd.DataFrame(list(itertools.product(*axes.values())), columns=list(SWEPT),
                         dtype=float)
    return axes, frame


def _study_config():
    """The configuration re-read with simcore's loader and types (as the CLI reads it): a
    quoted "0.2" stays a string and is refused, aliases and duplicate keys are refused."""
    from simcore.config import read_study_config

    cli_files = [Path(p).absolute() for p in workflow.config_settings.configfiles]
    files = [Path(p).absolute() for p in workflow.configfiles]
    ordered = [p for p in files if p not in cli_files] + cli_files
    try:
        return read_study_config(ordered, workflow.config_settings.config)
    except simcore.ConfigError as exc:
        raise WorkflowError(f"invalid configuration: {exc}") from None


_full = _checked_config(_study_config())
config.clear()
config.update(_full)

AXES, GRID = _grid(config)
paramspace = Paramspace(GRID, filename_params="*")
PARAMS = paramspace.wildcard_pattern  # clearance~{clearance}_mu~{mu}_omega0~{omega0}_e_N~{e_N}

# One simulate (and one impacts) job loops over the batch axes for one combination of the other
# ("outer") axes: a run of the paper's case takes well under a second, less than the start of a
# job (Python, imports, Numba cache), so jobs of single runs would spend most time starting.
BATCH = [key for key in SWEPT if key in config["study"]["batch_axes"]]
OUTER = [key for key in SWEPT if key not in BATCH]
if OUTER:
    outer_space = Paramspace(GRID[OUTER].drop_duplicates().reset_index(drop=True),
                             filename_params="*")
    BATCH_NAME = outer_space.wildcard_pattern  # e.g. clearance~{clearance}_mu~{mu}
else:
    BATCH_NAME = "all"

RES = config["study"]["results_dir"].rstrip("/")
# Logs and benchmark tables are written while a job runs; they live outside the results folder,
# so that every file under results/ is a finished product.
LOGS = Path("logs", "_".join(Path(RES).relative_to(Path(RES).anchor).parts)).as_posix()

SUMMARY_NC = f"{RES}/summary.nc"
FIGURES = f"{RES}/figures"
# the reference run's figures until the figures job moves them into FIGURES (a temporary,
# hidden folder: Snakemake removes it once the figures are done)
REFERENCE_FIGURES = f"{RES}/.reference_figures"

ALL_RUNS = expand(f"{RES}/runs/{{p}}.nc", p=list(paramspace.instance_patterns))
ALL_IMPACTS = expand(f"{RES}/impacts/{{p}}.nc", p=list(paramspace.instance_patterns))


def _repair():
    """Before Snakemake decides what to run: remove outputs that cannot be opened and the
    impact tables of missing runs, so that the next run remakes them (simcore.study.repair). Only in
    the main process (not inside cluster jobs); a dry run, lint or report only reports."""
    from simcore.study.repair import looking_only, repair_outputs

    if not workflow.is_main_process:
        return
    dry = looking_only(sys.argv)
    for line in repair_outputs(ALL_RUNS, ALL_IMPACTS, SUMMARY_NC, remove=not dry):
        print(("would redo (dry run): " if dry else "repair: ") + line, file=sys.stderr)


_repair()


wildcard_constraints:
    clearance=r"[-+0-9.eE]+",
    mu=r"[-+0-9.eE]+",
    omega0=r"[-+0-9.eE]+",
    e_N=r"[-+0-9.eE]+",


def batch_files(kind):
    """Files of one batch: outer axes stay wildcards, batch axes take every grid value."""
    names = []
    for values in itertools.product(*(AXES[key] for key in BATCH)):
        fixed = dict(zip(BATCH, values))
        parts = [f"{key}~{fixed[key]}" if key in fixed else f"{key}~{{{key}}}" for key in SWEPT]
        names.append(f"{RES}/{kind}/{'_'.join(parts)}.nc")
    return names


def batch_points(wildcards):
    """The swept values of every run of one batch, as dicts of plain floats."""
    outer = {key: float(getattr(wildcards, key)) for key in OUTER}
    points = []
    for values in itertools.product(*(AXES[key] for key in BATCH)):
        fixed = dict(outer, **dict(zip(BATCH, values)))
        points.append({key: fixed[key] for key in SWEPT})
    return points


def run_length(omega0):
    """End time of a run [s]: (analysis.settle + study.revolutions) crank revolutions at omega0,
    rounded up to whole steps; solver.t_end where study.revolutions is null."""
    revolutions = config["study"]["revolutions"]
    if revolutions is None:
        return config["solver"]["t_end"]
    turns = config["analysis"]["settle"] + revolutions
    steps = math.ceil(turns * 2.0 * math.pi / abs(omega0) / config["solver"]["dt"] - 1e-9)
    return tidy(steps * config["solver"]["dt"])


def _check_run_lengths():
    if config["study"]["revolutions"] is None:
        return
    for omega0 in AXES["omega0"]:
        if omega0 == 0.0:
            raise WorkflowError(
                "invalid configuration: omega0: 0.0 is not allowed with study.revolutions "
                "(a run lasts (settle + revolutions) 2 pi/|omega0|); allowed: omega0 != 0, "
                "or study.revolutions: null")
        if run_length(omega0) > 1000.0:
            raise WorkflowError(
                f"invalid configuration: study.revolutions: {config['study']['revolutions']} "
                f"at omega0 = {omega0} rad/s gives t_end = {run_length(omega0):.4g} s; "
                "allowed: t_end <= 1000 s")


_check_run_lengths()


def run_config(point):
    """Configuration of one run: model and solver sections with the point's values set, and
    the run's length from study.revolutions (see run_length)."""
    cfg = {"model": copy.deepcopy(config["model"]), "solver": copy.deepcopy(config["solver"])}
    cfg["model"].update(point)
    cfg["solver"]["t_end"] = run_length(point["omega0"])
    return cfg


def batch_priority(wildcards):
    """Scheduling priority of a simulate job: the time steps of its runs, in thousands. Batches
    of unequal cost (say one speed each) then start longest first, so that the cheapest ones
    come last and the cores finish together; batches of equal cost are left in any order."""
    steps = sum(run_length(p["omega0"]) / config["solver"]["dt"] for p in batch_points(wildcards))
    return round(steps / 1000.0, 3)


def batch_configs(wildcards):
    """Configurations of the runs of one batch (a change of any value reruns the batch)."""
    return [run_config(p) for p in batch_points(wildcards)]


def _reference_point():
    """The grid point nearest to the model section (the paper's case), for the run figures."""
    scaled = GRID.copy()
    for key in SWEPT:
        span = (max(AXES[key]) - min(AXES[key])) or 1.0
        scaled[key] = (GRID[key] - config["model"][key]) / span
    best = int((scaled**2).sum(axis=1).idxmin())
    return {key: float(GRID.loc[best, key]) for key in SWEPT}


def _check_limits():
    """Step size and memory of every run of the grid (simcore.config.limits), before any job."""
    import warnings

    from simcore.config.limits import check_run

    for point in GRID.to_dict("records"):
        cfg = run_config({key: float(value) for key, value in point.items()})
        cfg = simcore.validate_config(dict(cfg, **{"study": config["study"]}))
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                check_run(cfg)
        except simcore.ConfigError as exc:
            where = ", ".join(f"{key}={value}" for key, value in point.items())
            raise WorkflowError(f"invalid configuration: run {where}: {exc}") from None
        for item in caught:
            print(f"WARNING: {item.message}", file=sys.stderr)


_check_limits()

REFERENCE = _reference_point()
REFERENCE_NAME = "_".join(f"{key}~{REFERENCE[key]}" for key in SWEPT)


def failed_points(summary_path):
    """Lines naming the failed runs recorded in a summary file (empty if none).

    Read with netCDF4 alone: Snakemake's process runs this at the end of the study, where
    importing xarray (with pandas and dask) would take longer than the rest of it."""
    import netCDF4
    import numpy as np

    if not Path(summary_path).exists():
        return []
    with netCDF4.Dataset(summary_path) as nc:
        failed = nc.variables["failed"]
        order = [failed.dimensions.index(key) for key in SWEPT]
        flags = np.ma.filled(failed[:], 0.0).transpose(order)
        values = {key: np.asarray(nc.variables[key][:], dtype=float) for key in SWEPT}
    return [", ".join(f"{key}={float(values[key][i])}" for key, i in zip(SWEPT, point))
            for point in np.argwhere(flags > 0)]
