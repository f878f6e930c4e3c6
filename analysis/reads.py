"""What a study reads back from its run files, and the check of ``study.keep`` against it.

A study's simulate job makes each run's impact table and summary numbers from the run in
memory, with every variable; the run file holds only the variables of ``study.keep``. Two later
jobs read run files again:

* the summary (:func:`analysis.summary.summarize`), where a table's stored numbers are missing
  or were made by other analysis code: :data:`SUMMARY_READS` of each model, and for a
  compliant run :data:`LIFE_READS` (its rating lives);
* the reference run's figures (:func:`analysis.figures.plot_run`,
  :func:`analysis.figures.plot_reference`), on the nonsmooth run: :data:`FIGURE_READS`.

A study whose ``study.keep`` leaves one of them out is refused before any job
(:func:`check_keep`), rather than failing in the last job or giving a summary with missing
numbers.

Every analysis reads a run's model settings through :func:`run_setting`.
"""

from __future__ import annotations

from collections.abc import Iterable

#: :func:`run_setting`'s default: the setting is required.
REQUIRED = object()


def run_setting(run_ds, key: str, default=REQUIRED):
    """A model setting of a run (``key`` as in the configuration's ``model`` section, e.g.
    ``"clearance"``): the run's attribute ``model.<key>``, which every run file states as
    configured, else (a file without it) its scalar coordinate of that name. (A study's
    coordinate of a swept category, ``bearing`` or ``clearance_class``, holds the category's
    int8 code, not its name.)

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run file's dataset.
    key : str
        The setting's name without the ``model.`` prefix.
    default : optional
        What a file that states neither gives; by default such a file is refused.

    Returns
    -------
    The value as the file stores it (callers convert to the type they need).

    Raises
    ------
    ValueError
        The file states neither and no default is given (naming ``model.<key>``).
    """
    name = f"model.{key}"
    if name in run_ds.attrs:
        return run_ds.attrs[name]
    if key in run_ds.coords and run_ds[key].size == 1 and "flag_meanings" not in run_ds[key].attrs:
        return run_ds[key].values.item()  # a scalar or length-1 coordinate
    if default is REQUIRED:
        raise ValueError(f"run dataset lacks the setting {name!r} (attribute) needed by the "
                         "analysis")
    return default


#: Run variables the summary numbers of a run of each contact model read.
SUMMARY_READS = {"nonsmooth": ("crank_angle", "iterations", "converged", "Lambda_N"),
                 "compliant": ("crank_angle", "iterations", "converged", "Lambda_N", "F_N")}
#: Run variables the rating lives of a compliant run read (the load per ball and race, and
#: where each ball is on its race).
LIFE_READS = ("Lambda_N", "crank_angle", "journal_x", "journal_y", "position", "angle")
#: Run variables the reference run's figures read (the nonsmooth run).
FIGURE_READS = ("Lambda_N", "position", "angle", "crank_angle", "slider_x", "journal_x",
                "journal_y", "iterations", "converged")


def keep_needs(models: Iterable[str]) -> dict[str, list[str]]:
    """The run variables a study of contact models ``models`` reads back from its run files.

    Returns
    -------
    dict
        {variable: what reads it}, in the order of first need.
    """
    readers: list[tuple[str, tuple[str, ...]]] = []
    for model in models:
        readers.append((f"the summary ({model} runs)", SUMMARY_READS[model]))
        if model == "compliant":
            readers.append(("the rating life (compliant runs)", LIFE_READS))
        if model == "nonsmooth":
            readers.append(("the reference run's figures", FIGURE_READS))
    needs: dict[str, list[str]] = {}
    for reader, names in readers:
        for name in names:
            needs.setdefault(name, [])
            if reader not in needs[name]:
                needs[name].append(reader)
    return needs


def check_keep(keep: Iterable[str], models: Iterable[str]) -> None:
    """Refuse a ``study.keep`` that leaves out a variable the study reads back.

    Raises
    ------
    simcore.ConfigError
        One line naming ``study.keep``, each missing variable and what reads it.
    """
    from simcore.config import ConfigError

    kept = set(keep)
    missing = {name: readers for name, readers in keep_needs(models).items()
               if name not in kept}
    if missing:
        what = "; ".join(f"{name!r} ({', '.join(readers)})" for name, readers in missing.items())
        raise ConfigError(f"study.keep lacks {what}; allowed: any list of run variables that "
                          "holds these (the default does)")
