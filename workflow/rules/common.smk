# Shared helpers of the study workflow: configuration checks, the study's plan, paths.
#
# Everything here runs when Snakemake parses the workflow, before any job starts: a bad
# configuration, or a study larger than study.max_runs, stops the study with one line naming
# the key. The plan itself (axes, grid, runs, cost, jobs) is simcore.study.plan.

import json
import logging
import os
import sys
from contextlib import contextmanager
from pathlib import Path

from snakemake.utils import validate

import simcore
from analysis.reads import check_keep
from simcore.config.parameters import registry
from simcore.study import plan


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


def _stop(exc):
    """Stop the study on a bad configuration (an exception or a message) with one line naming
    the key and exit code 2, as `python -m simcore run` does (a WorkflowError would add
    Snakemake's frame and the lines of this file around it)."""
    print(f"invalid configuration: {exc}", file=sys.stderr, flush=True)
    raise SystemExit(2)


def _checked_config(raw):
    """Validate the merged config (see _study_config); a bad one stops the study (_stop)."""
    cfg = dict(raw)
    try:
        full = simcore.validate_config(cfg)
    except simcore.ConfigError as exc:
        _stop(exc)
    # The same JSON schema again, through Snakemake's own validator (fills the same defaults):
    # the schema as simcore loads it, with the sweep keys generated from the model, solver and
    # analysis sections, written where Snakemake can read it. Snakemake 9 validates with the
    # draft 2020-12 rules, which read every keyword of our draft-07 schema the same way; its
    # three-line warning about the version is muted.
    schema_file = Path(".snakemake", "bearingsim", "config.schema.json").absolute()
    schema_file.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(simcore.load_schema(), indent=1)
    if not schema_file.exists() or schema_file.read_text() != text:
        tmp = schema_file.with_name(f".{schema_file.name}.{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, schema_file)
    with _quiet_schema_version():
        validate(full, str(schema_file))
    return full


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
        _stop(exc)


def _check_base_config():
    """Stop a study whose working folder lacks the base settings: Snakemake skips a missing
    ``configfile:`` without a word when a --configfile is given, and the study would run at
    the schema's defaults instead of the study's (another drive, modulus and window)."""
    if not Path(BASE_CONFIG).is_file():
        _stop(f"{BASE_CONFIG}: not found in {Path.cwd()} (the study's base settings, which "
              "--configfile files are merged over); allowed: run snakemake in the "
              "repository's folder, or --directory to it")


_check_base_config()
_GIVEN = _study_config()
_full = _checked_config(_GIVEN)
config.clear()
config.update(_full)


def _cores():
    """Jobs that run at once: -j/--cores (a dry run, or a cluster, counts -j as nodes)."""
    settings = getattr(workflow, "resource_settings", None)
    counts = [getattr(settings, "cores", None), getattr(settings, "nodes", None)]
    counts = [int(c) for c in counts if isinstance(c, (int, float)) and c >= 1]
    return max(counts, default=1)




# The study's axes ({section.key: values}), its size (stops above study.max_runs), its runs.
try:
    AXES = plan.study_axes(config)
    SIZE = plan.check_size(config, AXES, _cores())
    RUNS = plan.plan_runs(config, AXES)
    _WARNINGS = plan.check_runs(RUNS)  # consistency and limits of every run, before any job
    # a clearance the user gave (not the base settings') that a clearance class replaces
    _WARNINGS += simcore.config.replaced_clearance(
        _GIVEN, config, base=simcore.config.read_study_config([Path(BASE_CONFIG).absolute()]))
    check_keep(config["study"]["keep"], config["study"]["models"])  # what later jobs read
except simcore.ConfigError as exc:
    _stop(exc)
PARAMS = registry()
AXIS_NAMES = [PARAMS[key].name for key in AXES]  # coordinates and summary dimensions, in order
# the model settings every grid point shares: the summary's attributes model_<key>
FIXED_MODEL = plan.shared_model(config, AXES)
# swept analysis keys: the summary reads each run's own value (analysis.summary.summarize)
SWEPT_ANALYSIS = [key.split(".", 1)[1] for key in AXES if key.startswith("analysis.")]
RES = config["study"]["results_dir"].rstrip("/")


try:  # a results folder the study cannot use: braces, a file, others' files in figures/
    plan.check_results_dir(RES)
except simcore.ConfigError as exc:
    _stop(exc)
# Logs and benchmark tables are written while a job runs; they live outside the results folder,
# so that every file under results/ is a finished product.
LOGS = Path("logs", "_".join(Path(RES).relative_to(Path(RES).anchor).parts)).as_posix()

SUMMARY_NC = f"{RES}/summary.nc"
FIGURES = f"{RES}/figures"
# the reference run's figures until the figures job moves them into FIGURES (a temporary,
# hidden folder: Snakemake removes it once the figures are done)
REFERENCE_FIGURES = f"{RES}/.reference_figures"

# One simulate job per batch of runs of about study.batch_seconds of estimated work
# (simcore.study.plan.batches); its output is a small marker listing its runs, written once
# every run file and impact table of the batch is in place. The run files themselves are made
# by the job (each written to a temporary file and renamed), one per run:
#   results/runs/<params>.nc, results/impacts/<params>.nc                  (nonsmooth)
#   results/runs_compliant/<params>.nc, results/impacts_compliant/<params>.nc  (compliant twin)
# A job skips a run whose two files are there and carry its fingerprint (plan.fingerprint), so
# that a killed, repaired or regrouped study redoes only what is missing or changed.
BATCHES = {f"b{i + 1:04d}": runs for i, runs in
           enumerate(plan.batches(RUNS, config["study"]["batch_seconds"]))}
BATCH_OF = {(run.name, run.model): batch for batch, runs in BATCHES.items() for run in runs}
MARKER = f"{RES}/.batches/{{batch}}.json"
ALL_MARKERS = expand(MARKER, batch=list(BATCHES))
MODELS = list(config["study"]["models"])
RUN_FILES = {model: [run.paths(RES)[0] for run in RUNS if run.model == model] for model in MODELS}
TABLE_FILES = {model: [run.paths(RES)[1] for run in RUNS if run.model == model]
               for model in MODELS}
ALL_RUNS = [path for model in MODELS for path in RUN_FILES[model]]
ALL_IMPACTS = [path for model in MODELS for path in TABLE_FILES[model]]

def mark_redo():
    """--forceall, or --forcerun simulate: every run is made again, not only the missing ones.
    Called by the Snakefile's onstart (Snakemake's DAG settings are not yet known while it reads
    the workflow), it sets this variable for the jobs, which inherit the environment; nothing
    asks the user for it."""
    dag = getattr(workflow, "dag_settings", None)
    if dag is not None and (getattr(dag, "forceall", False)
                            or "simulate" in (getattr(dag, "forcerun", None) or ())):
        os.environ.update({"BEARINGSIM_STUDY_REDO": "1"})


def _repair():
    """Before Snakemake decides what to run: remove outputs that cannot be opened, the impact
    tables of missing runs, and the marker of every batch that misses a file, so that the next
    run remakes them (simcore.study.repair). Only in the main process (not inside cluster jobs);
    a dry run, lint or report only reports."""
    from simcore.study.repair import looking_only, repair_outputs

    if not workflow.is_main_process:
        return
    dry = looking_only(sys.argv)
    markers = {MARKER.format(batch=batch): [path for run in runs for path in run.paths(RES)]
               for batch, runs in BATCHES.items()}
    for line in repair_outputs(ALL_RUNS, ALL_IMPACTS, SUMMARY_NC, remove=not dry,
                               batches=markers):
        print(("would redo (dry run): " if dry else "repair: ") + line, file=sys.stderr)


_repair()


wildcard_constraints:
    batch=r"b[0-9]+",


def batch_runs(wildcards):
    """What the simulate job of a batch makes: per run its name, model, coordinates, run
    configuration, files, the variables it writes and its fingerprint."""
    out = []
    for run in BATCHES[wildcards.batch]:
        run_path, table_path = run.paths(RES)
        keep = run.keep(config["study"]["keep"])
        out.append({"name": run.name, "model": run.model, "coords": run.coordinates(),
                    "config": run.config, "run": run_path, "table": table_path, "keep": keep,
                    "fingerprint": plan.fingerprint(run, keep, AXES)})
    return out


def batch_priority(wildcards):
    """Scheduling priority of a simulate job: its estimated work [s], so that the longest
    batches start first and the cores finish together."""
    return round(sum(run.seconds for run in BATCHES[wildcards.batch]), 1)


def _reference_point():
    """The grid point nearest to the model section (the paper's case), for the run figures:
    numeric axes compared over their span, categories equal or not."""
    best, best_distance = None, None
    for point in plan.grid(AXES):
        distance = 0.0
        for key, value in point.items():
            param = PARAMS[key]
            section, name = key.split(".", 1)
            target = config[section][name]
            if target is None:
                continue  # (a setting null in the model section: no value to be near)
            if param.kind == "category":
                distance += 0.0 if value == target else 1.0
            else:
                span = (max(AXES[key]) - min(AXES[key])) or 1.0
                distance += ((float(value) - float(target)) / span) ** 2
        if best_distance is None or distance < best_distance:
            best, best_distance = point, distance
    return best


REFERENCE = _reference_point()
REFERENCE_NAME = plan.run_name(REFERENCE)
# (the reference run's figures read the nonsmooth run, whatever the order of study.models)
REFERENCE_MARKER = MARKER.format(batch=BATCH_OF[(REFERENCE_NAME, "nonsmooth")])
REFERENCE_FILES = dict(zip(("run", "impacts"), next(
    run.paths(RES) for run in RUNS if run.name == REFERENCE_NAME and run.model == "nonsmooth"),
    strict=True))


def _axis_name(key, setting):
    """The coordinate name of a study axis given as a sweep key or a name (study.figure_*)."""
    full = simcore.config.parameters.canonical(str(key))
    if full is None or full not in AXES:
        _stop(f"{setting}: {key!r} is not allowed; allowed: an axis of the study: "
              + ", ".join(AXIS_NAMES))
    return PARAMS[full].name


def _stored(key, value, setting):
    """A grid value of an axis as the summary stores it (a category as its code)."""
    full = simcore.config.parameters.canonical(str(key))
    param = PARAMS[full]
    try:
        if param.plain(value) in AXES[full]:
            stored = param.stored(value)
            return float(stored) if param.kind == "number" else stored.item()
    except (ValueError, TypeError):
        pass
    _stop(f"{setting}.{key}: {value!r} is not allowed; allowed: one of the axis' values "
          + ", ".join(map(str, AXES[full])))


# The layout of the study's heat maps: axes and held values by coordinate name (as the summary
# names its dimensions), and the reference point's values, where other axes are held.
FIGURE_AXES = [_axis_name(key, "study.figure_axes")
               for key in (config["study"]["figure_axes"] or [])] or None
FIGURE_FIXED = {_axis_name(key, "study.figure_fixed"): _stored(key, value, "study.figure_fixed")
                for key, value in config["study"]["figure_fixed"].items()}
REFERENCE_COORDS = {PARAMS[key].name: _stored(key, value, "reference")
                    for key, value in REFERENCE.items()}
try:  # (the figures job checks them again on the summary)
    plan.check_figure_settings({PARAMS[key].name: len(values) for key, values in AXES.items()},
                               FIGURE_AXES, FIGURE_FIXED)
except simcore.ConfigError as exc:
    _stop(exc)
# the study's size once every setting is checked (a bad one stops the study in one line)
if workflow.is_main_process:
    print(f"study: {SIZE}", file=sys.stderr, flush=True)
    for line in _WARNINGS:
        print(f"WARNING: {line}", file=sys.stderr)


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
        dims = list(failed.dimensions)
        flags = np.ma.filled(failed[:], 0.0)
        values = {}
        for dim in dims:
            var = nc.variables.get(dim)
            labels = np.asarray(var[:]) if var is not None else np.arange(len(nc.dimensions[dim]))
            meanings = getattr(var, "flag_meanings", None) if var is not None else None
            values[dim] = (meanings.split() if meanings else labels)
    lines = []
    for point in np.argwhere(flags > 0):
        lines.append(", ".join(f"{dim}={values[dim][i]}" for dim, i in zip(dims, point,
                                                                          strict=True)))
    return lines
