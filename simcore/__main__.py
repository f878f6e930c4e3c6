import gc
import sys

from .cli import main

code = main()
# The process ends here. Its shut-down would walk the few hundred thousand objects that
# NumPy, Numba, xarray and pandas left behind with the cyclic collector (0.8 s of the paper
# case's 2-3 s command); frozen, they are skipped, and freed with the process.
gc.freeze()
sys.exit(code)
