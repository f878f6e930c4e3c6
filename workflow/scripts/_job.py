"""Helpers shared by the job scripts of the study workflow (log capture, thread count).

Snakemake runs each script as ``python <copy of script>`` with this folder on ``sys.path``.
The scripts only import and call functions of ``simcore`` and ``analysis``; no Numba kernels
live here (kernels defined in a script would never hit Numba's cache).
"""

from __future__ import annotations

import os
import sys
import traceback
from contextlib import contextmanager

from simcore.startup.patches import freeze_heap_at_exit  # noqa: E402

# A job's process ends with its script: its shut-down skips the objects alive then (start-up
# patch gc_freeze; the scripts close their files before they end: written and renamed).
freeze_heap_at_exit()


@contextmanager
def job_log(path, mode="w"):
    """Send all the job prints (Python and C level, stdout and stderr) to the log file ``path``
    (``mode`` "w": a new log, "a": append to it).

    Yields a text stream to the terminal's stderr, for the few lines the user must see there
    (a failed run). An exception is written to the log, then raised again.
    """
    sys.stdout.flush()
    sys.stderr.flush()
    saved_out, saved_err = os.dup(1), os.dup(2)
    terminal = os.fdopen(os.dup(saved_err), "w", buffering=1)
    with open(path, mode, buffering=1, encoding="utf-8") as log:
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
        try:
            yield terminal
        except BaseException:
            traceback.print_exc()
            raise
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved_out, 1)
            os.dup2(saved_err, 2)
            os.close(saved_out)
            os.close(saved_err)
            terminal.close()


@contextmanager
def folder_in_place(target):
    """A hidden folder next to the folder ``target`` to write into; when the block ends without
    an error it replaces ``target``, otherwise it is removed: ``target`` never holds a
    half-written set of files (nor does a killed earlier attempt's folder stay behind)."""
    import shutil
    import tempfile
    from pathlib import Path

    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale([target])
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    tmp.chmod(0o755)
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if target.exists():
        shutil.rmtree(target)
    os.replace(tmp, target)


def remove_stale(paths):
    """Remove temporary files left by a killed earlier attempt at writing ``paths``.

    Outputs are written to ``.<name>.<random>.tmp`` (or a ``.<name>.<random>`` folder) next to
    the target and renamed into place; a job killed with SIGKILL cannot remove its own.
    """
    import shutil
    from pathlib import Path

    for path in map(Path, paths):
        if path.parent.is_dir():
            for stale in path.parent.glob(f".{path.name}.*"):
                if stale.is_dir():
                    shutil.rmtree(stale, ignore_errors=True)
                else:
                    stale.unlink(missing_ok=True)


def set_threads(threads):
    """Give Numba the job's thread count (Snakemake sets OMP_NUM_THREADS only)."""
    import numba

    numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    return numba.get_num_threads()


def label(point):
    """``clearance=0.0004, mu=0.01, ...`` for messages (``point``: ``{section.key: value}``)."""
    from simcore.study.plan import label as point_label

    return point_label(point)


def process_start_time():
    """Wall-clock time at which this process started [s since the epoch] (Linux; NaN
    elsewhere): from its start in clock ticks after boot and the machine's uptime."""
    import time

    try:
        with open("/proc/self/stat") as fh:
            ticks = int(fh.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as fh:
            uptime = float(fh.read().split()[0])
    except (OSError, ValueError, IndexError):
        return float("nan")
    return time.time() - (uptime - ticks / os.sysconf("SC_CLK_TCK"))


def timing_line(**numbers):
    """One line ``TIMING {json}`` for the job's log: where the job's time went, read by
    benchmarks/bench_study.py (times [s since the epoch], durations [s])."""
    import json

    return "TIMING " + json.dumps({key: round(float(value), 4) for key, value in numbers.items()})
