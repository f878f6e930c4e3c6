"""The two ways the kernels are compiled.

:data:`kernel` is Numba's ``njit`` with the on-disk cache and NumPy's error model (a division by
zero gives inf or NaN, which the convergence and energy checks catch, instead of a compiled
exception path). :data:`step_kernel` is the same for the kernels of the time step that allocate
no array: they are compiled without Numba's reference counting. With it, every array handed to
a function (each member of a bundle too) and every row view gets two atomic updates of its
count, some 15 % of a step's time in the bearing's small functions. Such a kernel must not
create an array (``np.zeros``, ``.copy()``), nor keep one a callee returns: it would never be
freed. Views (``a[i]``, ``a[:n]``) are fine, they borrow the parent's memory.

Both release Python's global interpreter lock while they run (``nogil``): runs started from
several Python threads integrate in parallel (each run has its own arrays; the kernels keep no
state between calls).
"""

from __future__ import annotations

from numba import njit

#: Kernels that may allocate arrays. (Reference counting is asked for explicitly: a callee
#: inherits the caller's setting otherwise, and a step kernel calls some of these.)
kernel = njit(cache=True, error_model="numpy", _nrt=True, no_cfunc_wrapper=True, nogil=True)

#: Kernels that allocate nothing (see the module docstring).
step_kernel = njit(cache=True, error_model="numpy", _nrt=False, no_cfunc_wrapper=True,
                   nogil=True)
