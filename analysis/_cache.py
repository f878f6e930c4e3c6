"""The analysis kernels' Numba cache folder: the simulation kernels' one, whatever was imported
first. Numba picks a kernel's cache folder when the kernel is defined, so ``analysis`` imports
this module before any submodule that defines one; otherwise the study's warm-up (which
imports analysis first) and its jobs (simcore first) would keep two caches, and the jobs would
compile the analysis kernels again."""

from simcore.startup.numba_cache import configure_cache

configure_cache()
