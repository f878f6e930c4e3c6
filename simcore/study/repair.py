"""Repair of a study's outputs: what is missing or cannot be opened is made again.

Snakemake decides what to run from the files that exist and their times. A run file that was
truncated (a full disk, a copy cut short) still exists, so Snakemake would not redo it and every
later step reading it would fail; a run file that was deleted is an intermediate whose products
(impact tables, summary) still exist, so Snakemake would find nothing to do. This module runs
where Snakemake decides (when the workflow is parsed) and, before Snakemake looks:

- removes every output netCDF file that cannot be opened;
- removes the impact table of every run file that is missing, so that the simulate job that
  makes both remakes them;
- removes the marker of every batch (the simulate job's output, ``results/.batches/<b>.json``)
  one of whose files is missing, so that Snakemake runs that batch again;
- removes the summary when it cannot be opened or when a file it summarises is missing (else
  Snakemake, finding the summary up to date, would not remake the missing intermediates).

The next ``snakemake`` then remakes exactly those and everything that depends on them; a batch
that runs again skips its runs whose files are in place and carry the run's fingerprint
(:func:`finished`).
"""

from __future__ import annotations

from pathlib import Path


def unreadable(path: str | Path) -> str | None:
    """Why the netCDF file ``path`` cannot be opened (one line), or None if it opens.

    Opening reads the HDF5 superblock and every header: a truncated file fails here (the
    stored end of file is beyond the file's size), as does a file that is not netCDF at all.
    """
    import netCDF4

    try:
        with netCDF4.Dataset(path, "r") as ds:
            for var in ds.variables.values():
                var.dimensions  # noqa: B018  (touch every header)
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


def finished(run, table, fingerprint: str) -> bool:
    """True when the run file ``run`` and its impact table ``table`` both open and carry the
    attribute ``study_fingerprint`` equal to ``fingerprint`` (the same run made them)."""
    import netCDF4

    for path in (run, table):
        if not Path(path).exists() or unreadable(path):
            return False
        try:
            with netCDF4.Dataset(path, "r") as ds:
                if getattr(ds, "study_fingerprint", None) != fingerprint:
                    return False
        except (OSError, RuntimeError, ValueError):
            return False
    return True


def repair_outputs(runs, impacts, summary, remove: bool = True, batches=None) -> list[str]:
    """Remove the outputs that must be made again; return one line per removed file.

    Parameters
    ----------
    runs, impacts : list of path
        Run files and their impact tables, in the same order.
    summary : path
        The study's summary file.
    remove : bool
        False: only report (a dry run).
    batches : dict, optional
        ``{marker: [files of the batch]}``: a marker one of whose files is missing (or removed
        here) is removed too.
    """
    lines = []

    def drop(path: Path, why: str) -> None:
        lines.append(f"{path}: {why}; it will be made again")
        if remove:
            path.unlink(missing_ok=True)

    runs, impacts, summary = [Path(p) for p in runs], [Path(p) for p in impacts], Path(summary)
    for run, table in zip(runs, impacts, strict=True):
        run_missing = not run.exists()
        if not run_missing:
            why = unreadable(run)
            if why:
                drop(run, f"cannot be opened ({why})")
                run_missing = True
        if table.exists():
            if run_missing:
                drop(table, f"its run file {run.name} is missing")
            else:
                why = unreadable(table)
                if why:
                    drop(table, f"cannot be opened ({why})")
    def gone(path: Path) -> bool:
        return not path.exists() or (not remove and any(line.startswith(f"{path}:")
                                                        for line in lines))

    for marker, files in (batches or {}).items():
        marker = Path(marker)
        lost = [p for p in map(Path, files) if gone(p)]
        if marker.exists() and lost:
            drop(marker, f"{len(lost)} of its batch's files are missing ({lost[0].name} ...)")
    if summary.exists():
        missing = [p for p in runs + impacts if gone(p)]
        why = unreadable(summary)
        if why:
            drop(summary, f"cannot be opened ({why})")
        elif missing:
            drop(summary, f"{len(missing)} of the files it summarises are missing")
    return lines


#: Snakemake options under which the workflow is only looked at, never run: a repair would
#: remove files that nothing then remakes
LOOK_ONLY_OPTIONS = frozenset({
    "-n", "--dry-run", "--dryrun", "--dry", "--lint", "--list", "-l", "--list-rules",
    "--list-target-rules", "--lt", "--summary", "-S", "--detailed-summary", "-D", "--dag",
    "--rulegraph", "--filegraph", "--d3dag", "--report", "--unlock", "--cleanup-metadata",
    "--cm", "--touch", "-t", "--list-changes", "--lc", "--list-input-changes", "--li",
    "--list-params-changes", "--lp", "--list-code-changes", "--list-untracked", "--lu",
    "--export-cwl", "--containerize", "--archive", "--print-compilation", "--debug-dag",
    "--delete-all-output", "--delete-temp-output", "--generate-unit-tests", "--version",
    "-v", "--help", "-h",
})


def looking_only(argv) -> bool:
    """True when Snakemake was called (``argv``) only to look at the workflow: a dry run, a
    lint, a report, a listing. Snakemake sets its dry-run flag only after the workflow is
    parsed, so the command line is read here."""
    import re

    for arg in list(argv)[1:]:
        name = arg.split("=", 1)[0]
        if name in LOOK_ONLY_OPTIONS:
            return True
        if re.fullmatch(r"-[A-Za-z]{2,}", arg) and "n" in arg[1:]:  # -np, -pn
            return True
    return False
