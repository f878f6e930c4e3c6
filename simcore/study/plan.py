"""The plan of a parameter study: its axes, its grid, the runs of each grid point (one per
contact model of ``study.models``), what each run costs, and the jobs that run them.

The Snakemake workflow (``workflow/rules/common.smk``) calls these functions when it parses the
configuration, before any job starts; they need no Snakemake and are tested on their own.

Axes
    The paper's four parameters (``clearance``, ``mu``, ``omega0``, ``e_N``) are axes of every
    study (their model value where not swept), followed by every other swept key, in the order
    of the registry of swept parameters (:mod:`simcore.config.parameters`).
Runs
    Each grid point runs with every model of ``study.models``: the nonsmooth run (the paper's
    method) and its compliant twin (:func:`twin_config`), same drive and window.
Cost
    A run's work is estimated from its number of steps and its model (:data:`COST`, measured on
    this project's 2-core machine, see docs/study.md); runs are grouped into jobs of about
    ``study.batch_seconds`` of estimated work (:func:`batches`), whatever the axes.
Size
    A study of more than ``study.max_runs`` runs stops before any job (:func:`check_size`).
"""

from __future__ import annotations

import ast
import copy
import hashlib
import itertools
import json
import math
import os
import sys
from collections import ChainMap
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Mapping

from ..config import ConfigError, check_consistency
from ..config.parameters import BASE_AXES, registry, run_name, sweep_axes, tidy
from ..model.driver import CONTACT_MODELS

#: Contact models a study can run at each grid point (code = position: the ``model`` axis).
MODELS = CONTACT_MODELS
#: Folders of the run files and impact tables of each model, under ``study.results_dir``.
FOLDERS = {"nonsmooth": ("runs", "impacts"),
           "compliant": ("runs_compliant", "impacts_compliant")}
#: Variables of ``study.keep`` a compliant twin does not write: the velocities of the restart
#: state, which only a compliant zoom reads (a twin is not zoomed), and the nonsmooth free
#: approach speed; so its file (the same samples, plus ``F_N``) stays smaller than the
#: nonsmooth run's. It keeps the positions: its rating life reads the balls' places.
TWIN_DROPS = ("velocity", "angular_velocity", "vn_free")
#: Analysis settings that make a twin's configuration (:func:`twin_config`) and that no run
#: reads itself.
TWIN_SETTINGS = ("twin_rho_inf", "twin_tol_clearance")
#: Analysis settings that only a run's summary numbers read (no run, no impact table's own
#: variable): a study's runs are not made again for them (:func:`fingerprint`); a kept run's
#: files get the new values (:func:`analysis.study_tables.refresh_summary_settings`), and the
#: summary computes a run's numbers again from its run file where its table's were made with
#: other values (:mod:`analysis.summary`, which reads them from here).
SUMMARY_ONLY_SETTINGS = ("force_levels", "life_conformity", "life_load_rating")
#: A base axis that other keys determine (``{base axis: (key, what its value depends on)}``):
#: where the key is swept, or set while what its value depends on is swept, the base axis is
#: left out of the study's axes and each run's value comes from the key
#: (:func:`resolve_point`), e.g. the clearance of a clearance class, which depends on the
#: bearing's bore; the summary gives it as a coordinate over those of them that are swept
#: (:func:`determiners`). Where the key is set and nothing it depends on is swept, the base axis
#: holds the one value it determines (a list swept beside is not used, as its points would
#: all run at that value).
DETERMINED = {"model.clearance": ("model.clearance_class", "model.bearing")}
#: Jobs a study is split into at least (or one per run): two or four cores share a small study.
MIN_JOBS = 4
#: The files a study's figures job writes into ``<study.results_dir>/figures``, the folder it
#: (and Snakemake, before the job) replaces as a whole: the heat maps, pairs and life figures of
#: :func:`analysis.figures.plot_study`, the reference run's figures (``plot_run`` and
#: ``plot_reference`` with the prefix ``reference``), the summary table
#: (workflow/scripts/figures.py), and the timestamp Snakemake may keep in a folder output.
#: A figures folder holding anything else is refused before any job (:func:`check_results_dir`).
FIGURE_FILES = ("study_*.png", "pairs_*.png", "life_*.png", "reference_*.png",
                "summary_table.csv", ".snakemake_timestamp")


@dataclass(frozen=True)
class Cost:
    """Seconds of work of one run on one core (the estimate of :func:`estimate_seconds`).

    Measured with ``python benchmarks/bench_study.py --default 1 --large`` (docs/study.md,
    "Cost"): the job logs' TIMING lines give each part's time summed over the runs of a study,
    which the script prints per step, run, zoom and job beside these constants.
    """

    nonsmooth_step: float = 45e-6   # integration of one nonsmooth step of a steady run [s]
    compliant_step: float = 9e-6    # one fixed compliant step of a steady run [s]
    per_run: float = 0.17           # run file, impact extraction, table file [s]
    per_zoom: float = 0.013         # one of the analysis.zoom_top zooms a run asks for [s]
                                    # (runs share zooms between rows: fewer are made)
    per_job: float = 1.0            # process start, imports, Numba cache load of a job [s]
    adaptive_share: float = 0.3     # an adaptive twin's integration over the same twin's at
                                    # the fixed step of twin_step [-]
    # the jobs after the simulations (the rules' benchmark files, logs/<results>/*.tsv):
    summary_job: float = 1.0        # the summary job's start [s]
    summary_per_run: float = 0.015  # reading one run's numbers into the summary [s]
    grid_figures: float = 3.0       # the grid's heat maps, two swept axes [s]
    per_axis_pair: float = 2.0      # ... and per pair of axes where three or more are swept
    reference_figures: float = 5.5  # the reference run's figures (beside the grid's) [s]


COST = Cost()


@dataclass
class Run:
    """One run of a study."""

    name: str            # file stem, the same for every model of a grid point
    model: str           # "nonsmooth" or "compliant"
    point: dict          # {section.key: value} of the study's axes
    config: dict         # its model, solver and analysis sections
    seconds: float       # estimated work [s]

    def paths(self, results: str) -> tuple[str, str]:
        """(run file, impact table) under the results folder ``results``."""
        runs, impacts = FOLDERS[self.model]
        return f"{results}/{runs}/{self.name}.nc", f"{results}/{impacts}/{self.name}.nc"

    def keep(self, keep) -> list[str]:
        """The variables of ``study.keep`` this run writes (:data:`TWIN_DROPS`)."""
        if self.model == "nonsmooth":
            return list(keep)
        return [name for name in keep if name not in TWIN_DROPS]

    def coordinates(self) -> dict:
        """The point with the contact model: the scalar coordinates of the run's files."""
        return dict(self.point, **{"model.contact_model": self.model})


def study_axes(cfg: Mapping[str, Any]) -> dict[str, list]:
    """The axes of a validated study configuration: ``{section.key: values}``.

    Raises
    ------
    ConfigError
        One line naming the sweep key (see :func:`simcore.config.parameters.sweep_axes`),
        ``sweep.solver.t_end`` swept while ``study.revolutions`` sets each run's length, or
        ``study.models`` without ``nonsmooth``.
    """
    try:
        swept = sweep_axes(cfg.get("sweep", {}))
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    models = list(cfg["study"].get("models", ["nonsmooth"]))
    if "nonsmooth" not in models:
        raise ConfigError(f"study.models: {models!r} is not allowed; allowed: a list with "
                          "nonsmooth (each twin and the reference run's figures are made from "
                          "a grid point's nonsmooth run)")
    if "solver.t_end" in swept and cfg["study"].get("revolutions") is not None:
        raise ConfigError("sweep.solver.t_end: not allowed while study.revolutions sets each "
                          "run's length; allowed: study.revolutions: null")
    params = registry()
    axes = {}
    for key in params:
        by, depends = DETERMINED.get(key, (None, None))
        if by in swept or (depends in swept and _setting(cfg, by) is not None):
            # the swept keys set this axis' value per run; a list of it beside (the default
            # study's, merged under a smaller configuration) is not an axis
            continue
        if by is not None and _setting(cfg, by) is not None:
            # (validate_config has set this key's value from ``by``)
            section, name = key.split(".", 1)
            axes[key] = [params[key].plain(cfg[section][name])]
        elif key in swept:
            axes[key] = swept[key]
        elif key in BASE_AXES:
            section, name = key.split(".", 1)
            axes[key] = [params[key].plain(cfg[section][name])]
    return axes


def check_results_dir(folder: str) -> None:
    """Refuse a ``study.results_dir`` the study cannot use without harm: with ``{`` or ``}``
    (Snakemake reads them as wildcards of every output path), one in (or at) a file, or one
    whose ``figures`` folder holds a file that is not a study's (:data:`FIGURE_FILES`): that
    folder is replaced as a whole at the end of the study, so a re-run replaces its own
    figures, and anything else there would be lost (``results_dir: docs``).

    Raises
    ------
    ConfigError
        One line naming ``study.results_dir`` and the first file in the way.
    """
    import fnmatch

    allowed = "allowed: a folder, or a path where one can be made"
    if "{" in folder or "}" in folder:
        raise ConfigError(f"study.results_dir: {folder!r} is not allowed ({{ and }} mark "
                          f"Snakemake's wildcards); {allowed}, without {{ or }}")
    for path in (Path(folder), *Path(folder).parents):
        if path.exists():
            if not path.is_dir():
                raise ConfigError(f"study.results_dir: {folder!r} is not allowed ({path} is a "
                                  f"file); {allowed}")
            break
    figures = Path(folder, "figures")
    if figures.is_symlink() or (figures.exists() and not figures.is_dir()):
        foreign = [figures]
    elif figures.is_dir():
        foreign = [entry for entry in sorted(figures.iterdir())
                   if entry.is_symlink() or not entry.is_file()
                   or not any(fnmatch.fnmatchcase(entry.name, p) for p in FIGURE_FILES)]
    else:
        foreign = []
    if foreign:
        raise ConfigError(f"study.results_dir: {folder!r} is not allowed: the study replaces "
                          f"{figures} as a whole, and {foreign[0]} is not a study's figure; "
                          f"allowed: a folder whose figures/ holds only "
                          f"{', '.join(FIGURE_FILES)} (move that file, or choose another "
                          "folder)")


def _setting(cfg: Mapping[str, Any], key: str) -> Any:
    """The value of ``section.key`` in a configuration (None where it is not set)."""
    section, name = key.split(".", 1)
    return cfg.get(section, {}).get(name)


def determiners(axes) -> dict[str, tuple]:
    """{base axis: the axes that set its value} for each base axis of :data:`DETERMINED` that
    ``axes`` (keys ``section.key``) leave out for keys they sweep: e.g. the clearance, set by a
    swept clearance class, by a swept bearing (a class set), or by both."""
    return {key: tuple(k for k in keys if k in axes) for key, keys in DETERMINED.items()
            if key not in axes and any(k in axes for k in keys)}


def shared_model(cfg: Mapping[str, Any], axes: Mapping[str, list]) -> dict:
    """The model settings every grid point of the study shares (the summary's attributes
    ``model_<key>``): neither swept nor set per point by a swept key (the clearance of a swept
    class, the radii, ball count, masses and conformities of a swept bearing)."""
    from ..model.bearing import SET_BY_ENTRY

    per_point = set(axes) | set(determiners(axes))
    if "model.bearing" in axes:
        per_point |= {f"model.{key}" for key in SET_BY_ENTRY}
    return {key: value for key, value in cfg["model"].items()
            if value is not None and key != "contact_model" and f"model.{key}" not in per_point}


def resolve_point(model: dict, point: Mapping[str, Any]) -> None:
    """Set in a run's ``model`` section the values its grid point's keys determine: a swept
    ``model.bearing`` its catalogue entry's radii, ball count, masses and conformities
    (:data:`simcore.model.bearing.SET_BY_ENTRY`; validate_config refuses them given beside such
    a sweep), and a ``model.clearance_class`` swept or set the clearance of the class for the
    bearing's bore (half the middle of the class's ISO 5753-1 range,
    :func:`simcore.model.bearing.model_clearance`)."""
    from ..model.bearing import SET_BY_ENTRY, resolve_model

    if "model.bearing" not in point and model.get("clearance_class") is None:
        return
    given = set(model) - (set(SET_BY_ENTRY) if "model.bearing" in point else set())
    try:
        model.update(resolve_model(model, given))
    except (KeyError, ValueError) as exc:
        raise ConfigError(str(exc).strip("'\"")) from None


def grid_size(axes: Mapping[str, list]) -> int:
    return math.prod(len(values) for values in axes.values())


def grid(axes: Mapping[str, list]):
    """The grid points ``{section.key: value}`` in order (the last axis varies fastest)."""
    keys = list(axes)
    for values in itertools.product(*axes.values()):
        yield dict(zip(keys, values, strict=True))


def run_length(cfg: Mapping[str, Any]) -> float:
    """End time of a run [s] of the run configuration ``cfg``: (analysis.settle +
    study.revolutions) crank revolutions at its omega0, rounded up to whole steps; solver.t_end
    where ``revolutions`` is None."""
    revolutions = cfg["study"]["revolutions"]
    if revolutions is None:
        return cfg["solver"]["t_end"]
    omega0 = float(cfg["model"]["omega0"])
    if omega0 == 0.0:
        raise ConfigError("omega0: 0.0 is not allowed with study.revolutions (a run lasts "
                          "(settle + revolutions) 2 pi/|omega0|); allowed: omega0 != 0, or "
                          "study.revolutions: null")
    dt = float(cfg["solver"]["dt"])
    turns = float(cfg["analysis"]["settle"]) + float(revolutions)
    steps = math.ceil(turns * 2.0 * math.pi / abs(omega0) / dt - 1e-9)
    t_end = tidy(steps * dt)
    if t_end > 1000.0:
        raise ConfigError(f"study.revolutions: {revolutions} at omega0 = {omega0} rad/s gives "
                          f"t_end = {t_end:.4g} s; allowed: t_end <= 1000 s")
    return t_end


def run_config(cfg: Mapping[str, Any], point: Mapping[str, Any]) -> dict:
    """Configuration of the nonsmooth run of a grid point: the model, solver and analysis
    sections with the point's values set, the run's length from ``study.revolutions``
    (:func:`run_length`), and ``study.revolutions`` itself."""
    out = {section: copy.deepcopy(dict(cfg[section])) for section in ("model", "solver",
                                                                     "analysis")}
    for key, value in point.items():
        section, name = key.split(".", 1)
        out[section][name] = value
    resolve_point(out["model"], point)
    out["model"]["contact_model"] = "nonsmooth"
    out["solver"]["t_end"] = run_length(dict(out, study=cfg["study"]))
    out["solver"]["output_dt"] = None
    return out


def twin_step(model: Mapping[str, Any], analysis: Mapping[str, Any], out_dt: float) -> float:
    """Step of a compliant twin [s]: the Hertz contact time of a ball on a race at the crank
    pin's speed (:func:`simcore.config.limits.hertz_contact_time`) over
    ``analysis.zoom_steps_per_contact`` (as a compliant zoom's), rounded down to a whole
    fraction of the output step ``out_dt`` [s]."""
    from ..config.limits import hertz_contact_time

    step = hertz_contact_time(model) / int(analysis["zoom_steps_per_contact"])
    return out_dt / max(1, math.ceil(out_dt / step - 1e-9))


def twin_tolerance(run_cfg: Mapping[str, Any]) -> float:
    """The local error tolerance of a twin's adaptive steps [m]: ``analysis.twin_tol_clearance``
    times the radial clearance ``model.clearance`` where that is larger than
    ``solver.adaptive_tol``, else (and where the key is null or 0) ``solver.adaptive_tol``.
    A ball's position error then stays a fixed part of the play it moves in (docs/study.md,
    "A tolerance that grows with the clearance")."""
    floor = float(run_cfg["solver"]["adaptive_tol"])
    per_clearance = run_cfg["analysis"].get("twin_tol_clearance") or 0.0
    return max(floor, tidy(float(per_clearance) * float(run_cfg["model"]["clearance"])))


def twin_config(run_cfg: Mapping[str, Any]) -> dict:
    """The compliant twin of a nonsmooth run: the same model, drive and window with Hertz
    contacts, its output step the nonsmooth step (``solver.output_dt``: per interval the
    largest force, so no peak is lost; the same samples as the nonsmooth run); no zooms (a
    compliant run is its own reference). Its steps are error-controlled (``solver.adaptive``),
    at most the output step, with the scheme's spectral radius ``analysis.twin_rho_inf`` (null:
    the run's ``solver.rho_inf``) and the tolerance of :func:`twin_tolerance`."""
    twin = copy.deepcopy(dict(run_cfg))
    twin["model"]["contact_model"] = "compliant"
    out_dt = float(run_cfg["solver"]["dt"])
    twin["solver"]["adaptive"] = True
    twin["solver"]["adaptive_tol"] = twin_tolerance(run_cfg)
    rho_inf = run_cfg["analysis"].get("twin_rho_inf")
    if rho_inf is not None:
        twin["solver"]["rho_inf"] = float(rho_inf)
    twin["solver"]["dt"] = out_dt
    twin["solver"]["output_dt"] = out_dt
    twin["analysis"]["zoom_top"] = 0
    return twin


def zooms_counted(zoom_top: int) -> int:
    """The zooms the estimate counts for a nonsmooth run of ``analysis.zoom_top``: at most
    five (its largest impacts share a few distinct times)."""
    return min(int(zoom_top), 5)


def work_seconds(contact_model: str, steps: float, zoom_top: int = 0, adaptive: bool = False,
                 cost: Cost = COST) -> float:
    """Estimated work of one run [s on one core]: its steps times the step cost of its model,
    plus the files and the impact extraction, plus the zooms of a nonsmooth run
    (:func:`zooms_counted`, :data:`COST`). An adaptive compliant run is given the ``steps`` of
    the fixed step of :func:`twin_step` and costs ``cost.adaptive_share`` of that run."""
    if contact_model == "compliant":
        share = cost.adaptive_share if adaptive else 1.0
        return cost.per_run + share * steps * cost.compliant_step
    return cost.per_run + steps * cost.nonsmooth_step + zooms_counted(zoom_top) * cost.per_zoom


def estimate_seconds(cfg: Mapping[str, Any], cost: Cost = COST) -> float:
    """:func:`work_seconds` of a run configuration."""
    dt = float(cfg["solver"]["dt"])
    adaptive = cfg["model"]["contact_model"] == "compliant" and cfg["solver"].get("adaptive")
    if adaptive:
        dt = twin_step(cfg["model"], cfg["analysis"], dt)
    steps = float(cfg["solver"]["t_end"]) / dt
    return work_seconds(cfg["model"]["contact_model"], steps,
                        cfg["analysis"].get("zoom_top", 0), bool(adaptive), cost)


def _view(cfg: Mapping[str, Any], point: Mapping[str, Any]) -> dict:
    """The sections of ``cfg`` with the point's values on top, without copying."""
    over: dict[str, dict] = {section: {} for section in ("model", "solver", "analysis")}
    for key, value in point.items():
        section, name = key.split(".", 1)
        over[section][name] = value
    view = {section: ChainMap(values, cfg[section]) for section, values in over.items()}
    view["study"] = cfg["study"]
    return view


def point_seconds(cfg: Mapping[str, Any], point: Mapping[str, Any], models,
                  cost: Cost = COST) -> float:
    """Estimated work of a grid point's runs, one per model [s]: :func:`estimate_seconds` of
    the runs :func:`plan_runs` would make, without making them."""
    view = _view(cfg, point)
    t_end, dt = run_length(view), float(view["solver"]["dt"])
    total = 0.0
    for model in models:
        step = dt if model == "nonsmooth" else twin_step(view["model"], view["analysis"], dt)
        total += work_seconds(model, t_end / step, view["analysis"].get("zoom_top", 0),
                              model != "nonsmooth", cost)
    return total


def plan_runs(cfg: Mapping[str, Any], axes: Mapping[str, list] | None = None) -> list[Run]:
    """Every run of the study, grid point by grid point, in the order of ``study.models``."""
    axes = study_axes(cfg) if axes is None else axes
    runs = []
    models = list(cfg["study"]["models"])
    for point in grid(axes):
        name = run_name(point)
        base = run_config(dict(cfg), point)
        for model in models:
            run_cfg = base if model == "nonsmooth" else twin_config(base)
            runs.append(Run(name, model, point, run_cfg, estimate_seconds(run_cfg)))
    return runs


def duration(seconds: float) -> str:
    """``42 s``, ``3.5 min``, ``2 h 05 min``."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.1f} min"
    hours, minutes = divmod(round(seconds / 60), 60)
    return f"{hours} h {minutes:02d} min"


def downstream_seconds(n_runs: int, n_swept: int, cores: int, cost: Cost = COST) -> float:
    """Wall time of the jobs after the simulations [s]: the summary of ``n_runs`` runs, then
    the grid's figures (a pairs figure per quantity where ``n_swept`` >= 3 axes have more than
    one value) beside the reference run's figures on a second core."""
    pairs = n_swept * (n_swept - 1) // 2 if n_swept >= 3 else 0
    grid_figures = cost.grid_figures + cost.per_axis_pair * pairs
    summary = cost.summary_job + cost.summary_per_run * n_runs
    if int(cores) >= 2:
        return summary + max(grid_figures, cost.reference_figures)
    return summary + grid_figures + cost.reference_figures


def job_count(work: float, n_runs: int, batch_seconds: float,
              min_jobs: int = MIN_JOBS) -> int:
    """Jobs of about ``batch_seconds`` for ``work`` seconds of ``n_runs`` runs (at least
    ``min_jobs``, at most one per run)."""
    return min(n_runs, max(math.ceil(work / float(batch_seconds)), int(min_jobs)))


def size_line(cfg: Mapping[str, Any], axes: Mapping[str, list], cores: int,
              cost: Cost = COST) -> tuple[int, str]:
    """(number of runs, ``N grid points x M models = R runs in J jobs, estimated ...``) of a
    study, from the configuration alone, before any run is planned."""
    points = grid_size(axes)
    models = list(cfg["study"]["models"])
    n_runs = points * len(models)
    work = sum(point_seconds(cfg, point, models, cost) for point in grid(axes))
    n_jobs = job_count(work, n_runs, cfg["study"]["batch_seconds"])
    wall = (work + n_jobs * cost.per_job) / max(1, min(int(cores), n_jobs))
    after = downstream_seconds(n_runs, sum(len(values) > 1 for values in axes.values()), cores,
                               cost)
    line = (f"{points:,} grid point{'s' if points != 1 else ''} x {len(models)} "
            f"model{'s' if len(models) != 1 else ''} ({', '.join(models)}) = {n_runs:,} runs "
            f"in {n_jobs:,} jobs, estimated {duration(work)} of work: about {duration(wall)} "
            f"on {cores} core{'s' if cores != 1 else ''}, then {duration(after)} for the "
            "summary and figures")
    return n_runs, line


def check_size(cfg: Mapping[str, Any], axes: Mapping[str, list], cores: int) -> str:
    """The study's size line (:func:`size_line`); a study of more than ``study.max_runs``
    runs is refused.

    Raises
    ------
    ConfigError
        ``study.max_runs: ...`` with the count and the estimate, before any run is planned.
    """
    n_runs, line = size_line(cfg, axes, cores)
    limit = int(cfg["study"]["max_runs"])
    if n_runs > limit:
        raise ConfigError(f"study.max_runs: {line}; allowed: at most study.max_runs = "
                          f"{limit:,} runs (raise study.max_runs to run this study)")
    return line


def check_runs(runs: list[Run]) -> list[str]:
    """The checks that need several keys of each run (:func:`simcore.config.check_consistency`,
    a constant-drive run longer than its start-up) and the limits known before a run (step
    size, memory, contact step:
    :func:`simcore.config.limits.check_run_of_config`), for every run of the study.

    Returns
    -------
    list of str
        Distinct warnings (policy ``warn``).

    Raises
    ------
    ConfigError
        One line naming the run's point and the key.
    """
    import warnings

    from ..config.limits import check_run_of_config

    messages: list[str] = []
    for run in runs:
        try:
            check_consistency(run.config)
            _check_steady_window(run.config)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                found = check_run_of_config(run.config)
        except ConfigError as exc:
            raise ConfigError(f"run {label(run.point)} ({run.model}): {exc}") from None
        for text in list(found) + [str(item.message) for item in caught] + _unswept(run):
            if text not in messages:
                messages.append(text)
    return messages


def _unswept(run: Run) -> list[str]:
    """A swept key a run does not take (a compliant twin sets its own ``solver.rho_inf``,
    ``solver.adaptive``, ...) or does not read (:data:`SUMMARY_ONLY_SETTINGS`, and
    :data:`TWIN_SETTINGS` for a nonsmooth run): along that axis its points are one run,
    labelled apart and made once per value."""
    texts = []
    for key, value in run.point.items():
        section, name = key.split(".", 1)
        if section == "analysis" and (name in SUMMARY_ONLY_SETTINGS or (
                name in TWIN_SETTINGS and run.model == "nonsmooth")):
            reader = ("only the summary reads it" if name in SUMMARY_ONLY_SETTINGS
                      else "it sets the compliant twins' solver")
            texts.append(f"sweep.{key}: the {run.model} runs do not read it ({reader}); along "
                         f"this axis they are one run, made once per value")
            continue
        actual = run.config[section].get(name)
        same = (math.isclose(float(value), float(actual), rel_tol=1e-9)
                if isinstance(value, (int, float)) and isinstance(actual, (int, float))
                else value == actual)
        if not same:
            hint = (" (analysis.twin_rho_inf: null makes them follow it)"
                    if key == "solver.rho_inf" else "")
            texts.append(f"sweep.{key}: the {run.model} runs set {key} = {actual} themselves, "
                         f"whatever the swept value; along this axis they are one run, "
                         f"labelled apart{hint}")
    return texts


@dataclass(frozen=True)
class FigureSettingNames:
    """How messages name the settings of the study figures' layout: the study's keys (the
    default) or a command's options (:data:`FIGURE_OPTIONS`)."""

    axes: str = "study.figure_axes"
    fixed: str = "study.figure_fixed"
    fixed_axis: str = "study.figure_fixed.{axis}"  # one held axis

    def held(self, axis: str) -> str:
        return self.fixed_axis.format(axis=axis)


FIGURE_KEYS = FigureSettingNames()
#: the options of ``python -m analysis study-figures``
FIGURE_OPTIONS = FigureSettingNames("--axes", "--fixed", "--fixed {axis}")


def check_figure_settings(sizes: Mapping[str, int], figure_axes=None, figure_fixed=None,
                          names: FigureSettingNames = FIGURE_KEYS) -> list[str]:
    """The drawn axes of the study figures (``study.figure_axes``, ``study.figure_fixed``) on
    a grid of axes ``{name: number of values}``, checked before any job; messages name the
    settings by ``names``.

    Returns
    -------
    list of str
        The named figure axes that are swept (more than one value), in order; [] when
        ``figure_axes`` is not given.

    Raises
    ------
    ConfigError
        One line: an axis not of the grid, named twice, more than 4, both drawn and held, or
        only axes of one value.
    """
    fixed = dict(figure_fixed or {})
    named = list(figure_axes or [])
    for setting, axes in ((names.axes, named),
                          *((names.held(name), [name]) for name in fixed)):
        for name in axes:
            if name not in sizes:
                raise ConfigError(f"{setting}: {name!r} is not allowed; allowed: the swept "
                                  f"axes {', '.join(sizes)}")
    if not named:
        return []
    if len(set(named)) != len(named) or not 1 <= len(named) <= 4 or set(named) & set(fixed):
        raise ConfigError(f"{names.axes}: {named!r} is not allowed; allowed: 1 to 4 "
                          f"different swept axes, none of them in {names.fixed}")
    swept = [name for name in named if sizes[name] > 1]
    if not swept:
        raise ConfigError(f"{names.axes}: {named!r} is not allowed; allowed: at least one "
                          "axis with more than one value (swept: "
                          + ", ".join(n for n, k in sizes.items() if k > 1) + ")")
    return swept


def _check_steady_window(cfg: Mapping[str, Any]) -> None:
    """Refuse a constant-drive run that ends within its start-up (``analysis.settle``): its
    summary would hold no steady number. (A free crank slows down by an amount the run
    itself finds.)"""
    model, solver, settle = cfg["model"], cfg["solver"], cfg["analysis"]["settle"]
    if model["drive"] != "constant":
        return
    revolutions = solver["t_end"] * abs(model["omega0"]) / (2.0 * math.pi)
    if revolutions <= settle:
        raise ConfigError(f"solver.t_end: {solver['t_end']!r} s is {revolutions:.3g} crank "
                          f"revolutions, not more than analysis.settle ({settle}); allowed: a "
                          "run longer than its start-up (raise solver.t_end, or lower "
                          "analysis.settle)")


def label(point: Mapping[str, Any]) -> str:
    """``clearance=0.0004, mu=0.01, cage_stiffness=100000.0`` for messages."""
    params = registry()
    return ", ".join(f"{params[key].name}={value}" for key, value in point.items())


def batches(runs: list[Run], batch_seconds: float, min_jobs: int = MIN_JOBS) -> list[list[Run]]:
    """Group the runs into jobs of about ``batch_seconds`` of estimated work each.

    As many jobs as the work needs (at least ``min_jobs``, at most one per run), filled
    longest run first into the least loaded job (so that the jobs' estimates come out nearly
    equal), each job's runs then in the study's order; jobs in decreasing estimated work.
    """
    if not runs:
        return []
    n_jobs = job_count(sum(run.seconds for run in runs), len(runs), batch_seconds, min_jobs)
    loads = [0.0] * n_jobs
    members: list[list[int]] = [[] for _ in range(n_jobs)]
    order = sorted(range(len(runs)), key=lambda i: -runs[i].seconds)
    for i in order:
        job = min(range(n_jobs), key=lambda j: (loads[j], j))
        loads[job] += runs[i].seconds
        members[job].append(i)
    jobs = [sorted(m) for m in members if m]
    jobs.sort(key=lambda m: -sum(runs[i].seconds for i in m))
    return [[runs[i] for i in m] for m in jobs]


#: the sources that make a run's two files (:func:`code_digest`), under the repository: every
#: module of these packages but those that cannot change a number of the files
CODE_PACKAGES = ("simcore", "analysis")
CODE_EXCLUDED = ("simcore/startup", "simcore/cli.py", "simcore/__main__.py",
                 "analysis/figures.py", "analysis/__main__.py")


#: where :func:`source_digest` keeps the code digests of the sources it has read (a file per
#: installation, beside this module's compiled code), so that a process pays for parsing only
#: after an edit
DIGEST_CACHE = Path(__file__).resolve().parent / "__pycache__" / "source_digests.json"
DIGEST_CACHE_ENTRIES = 8


@lru_cache(maxsize=1)
def code_digest() -> str:
    """A digest of the Python sources that make a run and its impact table
    (:func:`source_digest` of this installation): files made by other code are made again, as
    files of another configuration are (the package version does not move with an edit, nor
    with a checkout of other commits in an editable install)."""
    return source_digest(Path(__file__).resolve().parents[2])


def source_digest(root: Path, packages=CODE_PACKAGES, excluded=CODE_EXCLUDED) -> str:
    """A digest of the ``*.py`` files of ``packages`` under ``root``, but ``excluded`` (paths
    under ``root``, files or folders): their paths and their code (:func:`code_text`), so that
    an edit of comments, docstrings or layout alone leaves it as it is.

    Parsing the sources takes a few tenths of a second; the digest of sources already read is
    looked up (:data:`DIGEST_CACHE`, by a digest of their bytes and the Python version, whose
    syntax trees differ)."""
    files = []
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            name = path.relative_to(root).as_posix()
            if not any(name == x or name.startswith(x + "/") for x in excluded):
                files.append((name, path.read_bytes()))
    raw = hashlib.sha1(repr(sys.version_info[:2]).encode())
    for name, source in files:
        raw.update(name.encode() + b"\0" + source)
    known = _read_digest_cache()
    key = raw.hexdigest()
    if key not in known:
        digest = hashlib.sha1()
        for name, source in files:
            digest.update(name.encode())
            digest.update(code_text(source, name))
        known = {k: known[k] for k in list(known)[-(DIGEST_CACHE_ENTRIES - 1):]}
        known[key] = digest.hexdigest()[:16]
        _write_digest_cache(known)
    return known[key]


def _read_digest_cache() -> dict:
    try:
        known = json.loads(DIGEST_CACHE.read_text())
    except (OSError, ValueError):
        return {}
    return known if isinstance(known, dict) else {}


def _write_digest_cache(known: dict) -> None:
    """Write to a file of this process, then rename it into place: jobs that start together
    never read half a file. A read-only installation goes without."""
    partial = DIGEST_CACHE.with_name(f"{DIGEST_CACHE.name}.{os.getpid()}.tmp")
    try:
        DIGEST_CACHE.parent.mkdir(exist_ok=True)
        partial.write_text(json.dumps(known))
        os.replace(partial, DIGEST_CACHE)
    except OSError:
        try:
            partial.unlink(missing_ok=True)
        except OSError:
            pass


def code_text(source: bytes, name: str = "<source>") -> bytes:
    """What a module does, as text: its syntax tree without positions and without the bare
    string statements (docstrings, which make no number); comments and layout are not in a
    tree. A file that does not parse counts as its bytes."""
    try:
        tree = ast.parse(source, filename=name)
    except SyntaxError:
        return source
    for node in ast.walk(tree):
        for field in ("body", "orelse", "finalbody"):
            body = getattr(node, field, None)
            if isinstance(body, list) and body:
                kept = [s for s in body if not _is_bare_string(s)]
                setattr(node, field, kept or [ast.Pass()])
    return ast.dump(tree).encode()


def _is_bare_string(statement) -> bool:
    return (isinstance(statement, ast.Expr) and isinstance(statement.value, ast.Constant)
            and isinstance(statement.value.value, str))


def fingerprint(run: Run, keep, axes) -> str:
    """A hash of everything that makes a run's files: its configuration, the point with its
    model, the study's axes, ``study.keep``, the package version and the code that makes
    them (:func:`code_digest`). A run whose files carry the same fingerprint (attribute
    ``study_fingerprint``) is not made again.

    Left out are the analysis settings neither file depends on: :data:`TWIN_SETTINGS` (a
    twin's configuration holds what they set) and :data:`SUMMARY_ONLY_SETTINGS` (only the
    summary reads them), so that changing one of them does not make the runs again."""
    from .. import __version__

    config = dict(run.config)
    config["analysis"] = {key: value for key, value in run.config["analysis"].items()
                          if key not in TWIN_SETTINGS and key not in SUMMARY_ONLY_SETTINGS}
    text = json.dumps({"config": config, "point": run.coordinates(),
                       "axes": list(axes), "keep": list(keep), "version": __version__,
                       "code": code_digest()}, sort_keys=True, default=str)
    return hashlib.sha1(text.encode()).hexdigest()
