"""Compile (or load from Numba's cache) every kernel of the study, once, before the jobs start.

Run by the ``onstart`` step of the workflow (``workflow/rules/simulate.smk``) as a plain Python
process, not as a rule: without it, each of the first parallel jobs would compile the same
kernels at the same time (minutes on 2 cores after an install) and print nothing meanwhile.
Numba keeps the compiled code in ``__pycache__`` next to the sources, where every job then
finds it. A few steps of the paper's case (an impact at 1.5 ms) go through the simulation and
through the impact analysis, which has kernels of its own, and one short compliant zoom of that
impact (the kernels of the compliant model, which the simulate jobs use for ``F_max_zoom``).
"""

import sys
import time

start = time.perf_counter()
import analysis  # noqa: E402
import simcore  # noqa: E402

cfg = simcore.load_config(overrides=["solver.t_end=0.003"])
run = simcore.run(cfg)
impacts = analysis.extract_impacts(run)
zoom_start = time.perf_counter()
simcore.zoom(run, 1.5e-3, window=2e-5, dt=1e-6)
print(f"simulation kernels: {run.attrs['compile_time_s']:.1f} s; "
      f"compliant zoom kernels: {time.perf_counter() - zoom_start:.1f} s; "
      f"analysis of {impacts.sizes.get('impact', 0)} impact(s) included; "
      f"total {time.perf_counter() - start:.1f} s (python {sys.version.split()[0]})")
