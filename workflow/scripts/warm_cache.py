"""Compile (or load from Numba's cache) every kernel of the study, once, before the jobs start.

Run by the ``onstart`` step of the workflow (``workflow/rules/terminal.smk``) as a plain Python
process, not as a rule: without it, each of the first parallel jobs would compile the same
kernels at the same time (minutes on 2 cores after an install) and print nothing meanwhile.
Numba keeps the compiled code in ``__pycache__`` next to the sources, where every job then
finds it. A few steps of the paper's case (an impact at 1.5 ms) go through the simulation and
through the impact analysis, which has kernels of its own, and one short compliant zoom of that
impact (the kernels of the compliant model, which the simulate jobs use for ``F_max_zoom``).
The compliant kernels are compiled meanwhile by a second process, so that two cores share a
cold compilation (and the run's own warm-up shares its part with a third,
``simcore.startup.parallel_compile``). Two processes compile at once only where Numba's cache
saves are locked between them (start-up patch ``parallel_compile``); otherwise the compliant
kernels are compiled here, after the others.

After a success it leaves a stamp file in the Numba cache folder (:func:`warm_stamp`); while the
stamp matches the kernel sources, the next study skips the warm-up (which otherwise costs 2-3 s
of a new process loading the cache before the first job starts).
"""

import hashlib
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: the files that define Numba kernels: Numba checks a cached kernel against its file's
#: modification time and size, so the stamp does too (and the cache folder of
#: simcore.startup.numba_cache is named after the kernel sources' contents)
KERNEL_SOURCES = ("simcore/kernels/*.py", "analysis/forces.py", "analysis/filtering.py")


def warm_stamp() -> Path:
    """The file whose existence says that the warm-up succeeded for the kernel sources as they
    are (names, sizes, modification times), this Python and this Numba; it lives in the Numba
    cache folder, so that clearing the cache clears it too."""
    from importlib.metadata import version

    from simcore.startup.numba_cache import cache_folder

    digest = hashlib.sha1(f"{sys.version} numba {version('numba')}".encode())
    for pattern in KERNEL_SOURCES:
        for path in sorted(ROOT.glob(pattern)):
            stat = path.stat()
            digest.update(f"{path.relative_to(ROOT)} {stat.st_size} {stat.st_mtime_ns}".encode())
    return Path(cache_folder()) / f"study-warm-{digest.hexdigest()[:16]}"


#: run by a second process: the kernels of the compliant model (those of the zooms), compiled
#: while this process compiles the nonsmooth ones and the analysis'
COMPLIANT_WARM_UP = (
    "import simcore, simcore.runner as s; "
    "s.warm_up(simcore.load_config(overrides=['model.contact_model=compliant', "
    "'solver.dt=1e-6']))"
)


if __name__ == "__main__":
    import subprocess

    start = time.perf_counter()
    import analysis
    import simcore
    from simcore.startup.patches import cache_writes_locked

    # Two cores compile at once: the compliant kernels in a second process (they share some
    # callees with the nonsmooth ones, which both compile; their cache saves are serialised by
    # simcore.startup.patches.lock_cache_writes, without which the zoom below compiles them
    # here). Should that process fail, the zoom below compiles them here too.
    compliant = None
    if cache_writes_locked():
        compliant = subprocess.Popen([sys.executable, "-c", COMPLIANT_WARM_UP],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True)

    cfg = simcore.load_config(overrides=["solver.t_end=0.003"])
    run = simcore.run(cfg)
    impacts = analysis.extract_impacts(run)
    nonsmooth_done = time.perf_counter()
    output, _ = compliant.communicate() if compliant is not None else ("", None)
    if compliant is not None and compliant.returncode != 0:
        print(f"the compliant warm-up process failed (exit {compliant.returncode}); the zoom "
              f"compiles here:\n{output}")
    zoom_start = time.perf_counter()
    simcore.zoom(run, 1.5e-3, window=2e-5, dt=1e-6)
    print(f"simulation kernels: {run.attrs['compile_time_s']:.1f} s; nonsmooth run and analysis "
          f"of {impacts.sizes.get('impact', 0)} impact(s) {nonsmooth_done - start:.1f} s; "
          f"compliant kernels ready {zoom_start - start:.1f} s; "
          f"zoom {time.perf_counter() - zoom_start:.1f} s; "
          f"total {time.perf_counter() - start:.1f} s (python {sys.version.split()[0]})")
    stamp = warm_stamp()
    for old in stamp.parent.glob("study-warm-*"):
        old.unlink(missing_ok=True)
    stamp.write_text("the study's warm-up compiled or loaded every kernel of these sources\n")
