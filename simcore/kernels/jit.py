"""The ways the kernels are compiled.

:data:`kernel` is Numba's ``njit`` with the on-disk cache and NumPy's error model (a division by
zero gives inf or NaN, which the convergence and energy checks catch, instead of a compiled
exception path). :func:`step_kernel` is the same for the kernels of the time step that allocate
no array: they are compiled without Numba's reference counting. With it, every array handed to
a function (each member of a bundle too) and every row view gets two atomic updates of its
count, some 15 % of a step's time in the bearing's small functions. Such a kernel must not
create an array (``np.zeros``, ``.copy()``), nor keep one a callee returns: it would never be
freed. Views (``a[i]``, ``a[:n]``) are fine, they borrow the parent's memory.

Both are for kernels that only other kernels call: they are compiled without a Python entry
(start-up patch ``numba_internal_kernels``, :func:`simcore.startup.patches.internal_njit`; a
call from Python still works, through a twin compiled on first use). A kernel that simcore
calls from Python is an :data:`entry_kernel` or :data:`entry_step_kernel`.

:data:`inline_kernel` is :func:`step_kernel` for small helpers that their callers take in
whole (see its comment); :data:`stage` is a named part of a larger kernel, compiled only as
part of it. :func:`loop_kernel` is :data:`entry_step_kernel` for a time loop. A step kernel's
and a time loop's libraries are only linked, their callees inlined as they were optimised in
their own libraries (see :func:`step_kernel`).

All release Python's global interpreter lock while they run (``nogil``): runs started from
several Python threads integrate in parallel (each run has its own arrays; the kernels keep no
state between calls).
"""

from __future__ import annotations

from numba import njit

from ..startup.patches import internal_njit, link_only

#: Options of kernels that may allocate arrays. (Reference counting is asked for explicitly: a
#: callee inherits the caller's setting otherwise, and a step kernel calls some of these.)
_ALLOCATING = dict(cache=True, error_model="numpy", _nrt=True, no_cfunc_wrapper=True, nogil=True)
#: Options of kernels that allocate nothing (see the module docstring).
_STEP = dict(cache=True, error_model="numpy", _nrt=False, no_cfunc_wrapper=True, nogil=True)

#: Kernels that may allocate arrays, called by other kernels only.
kernel = internal_njit(**_ALLOCATING)
#: The compilation of :func:`step_kernel`, which registers its kernels for linking first.
_step_njit = internal_njit(**_STEP)
#: :data:`kernel` and :func:`step_kernel` for kernels that simcore calls from Python.
entry_kernel = njit(**_ALLOCATING)
entry_step_kernel = njit(**_STEP)

#: Small step kernels that their callers take in whole (Numba's own inlining, before LLVM).
#: A call between kernels passes every array of its bundles as separate arguments (seven
#: words each: a ModelArrays is some ninety); for a helper called at every Newton iterate with
#: several bundles that copying cost more than its arithmetic (the compliant step's force
#: evaluation, residual and chord update, and the spring state of every spring: about a tenth
#: of a compliant step). The same arithmetic, so the same numbers.
inline_kernel = internal_njit(**_STEP, inline="always")

#: A named stage of a kernel (a part of a step kernel given a name of its own): inlined into
#: its caller in Numba's own representation, before typing, so that it is compiled as part
#: of the caller and not as a function of its own. Compiled on its own, each of these took 0.5
#: to 2 s of a cold compile: its library re-optimises all its callees, and the work bundle it
#: takes (some forty arrays) fills its argument list and its Python wrapper. Only kernels
#: call it (it is never compiled for Python).
stage = njit(inline="always", error_model="numpy", _nrt=False, no_cfunc_wrapper=True,
             nogil=True)


def step_kernel(func):
    """A kernel that allocates nothing, called by other kernels only (module docstring), whose
    library is only linked: its direct callees, each already optimised in its own library, are
    inlined into it and the argument passing cleaned up, not optimised a second time with it.

    Numba optimises each kernel's library as a whole with its callees' libraries linked in, so
    a kernel several calls above the arithmetic (the compliant step, its smooth stage) would
    have its callees optimised again in every caller: that lengthens the cold compile and
    gives slower code for the compliant step (docs/performance.md, "A cold compile", gives both
    figures). The arithmetic is IEEE without fast-math either way, so the results are the
    same to the bit. The linking is a start-up patch on Numba's internals
    (:func:`simcore.startup.patches.install_link_only`); without it (switched off, or another
    Numba) the kernel is optimised as Numba does.
    """
    return _step_njit(link_only(func))


def loop_kernel(func):
    """:data:`entry_step_kernel` for a time loop, its library only linked as a
    :func:`step_kernel`'s: the stages of a step, each already optimised in its own library, are
    inlined into the loop, not optimised a second time."""
    return entry_step_kernel(link_only(func))
