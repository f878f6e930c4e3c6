"""The ways the kernels are compiled.

:data:`kernel` is Numba's ``njit`` with the on-disk cache and NumPy's error model (a division by
zero gives inf or NaN, which the convergence and energy checks catch, instead of a compiled
exception path). :data:`step_kernel` is the same for the kernels of the time step that allocate
no array: they are compiled without Numba's reference counting. With it, every array handed to
a function (each member of a bundle too) and every row view gets two atomic updates of its
count, some 15 % of a step's time in the bearing's small functions. Such a kernel must not
create an array (``np.zeros``, ``.copy()``), nor keep one a callee returns: it would never be
freed. Views (``a[i]``, ``a[:n]``) are fine, they borrow the parent's memory.

:func:`loop_kernel` is :data:`step_kernel` for a time loop, whose callees (the stages of a step)
are large and already optimised: see its docstring.

All release Python's global interpreter lock while they run (``nogil``): runs started from
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

#: (library name, mangled-name prefix) of the :func:`loop_kernel` functions
_LINK_ONLY: set[tuple[str, str]] = set()
#: names of the loop libraries this process has linked (:func:`_link`), and of those where the
#: linking failed and Numba's whole optimisation ran instead
LINKED: list[str] = []
LINK_FAILED: list[str] = []


def loop_kernel(func):
    """:data:`step_kernel` for a time loop: its compiled callees are linked in as they are.

    Numba compiles every function into a library of its own, optimised as a whole with the
    libraries of its callees linked in (so that small callees get inlined), then turned into
    machine code. A time loop's callees are the stages of a step, each already optimised in its
    own library with its callees; optimising them all once more inside the loop's library took
    a fifth of a cold compile (the loop's library alone, some 4 s of 22 s) for no faster code.
    The loop's library is therefore only linked: its direct callees (called once or twice a
    step) are inlined into the loop and the argument passing cleaned up (the inliner, SROA,
    instcombine and CFG simplification, about 0.1 s), which keeps the speed of the fully
    optimised loop; the loop's own function has had the function-level optimisations every
    kernel gets. The arithmetic is IEEE without fast-math either way, so the results are the
    same to the bit.

    This uses a private method of Numba (``CPUCodeLibrary._optimize_final_module``); where that
    is missing or anything in the linking fails, the loop is optimised as any other kernel.
    """
    return step_kernel(link_only(func))


def link_only(func):
    """Register the Python function ``func`` so that the library Numba compiles for it is only
    linked (:func:`loop_kernel`); returns ``func``."""
    name = func.__qualname__
    path = func.__module__.split(".") + name.split(".")
    _LINK_ONLY.add((name, "_ZN" + "".join(f"{len(p)}{p}" for p in path)))
    return func


def _install_link_only() -> bool:
    """Make Numba only link the libraries of :func:`loop_kernel` functions.

    Returns True when the hook is in place (now or before)."""
    try:
        from numba.core.codegen import CPUCodeLibrary
    except ImportError:
        return False
    optimize = getattr(CPUCodeLibrary, "_optimize_final_module", None)
    if optimize is None:
        return False
    if getattr(optimize, "link_only", False):
        return True

    def _optimize_final_module(self):
        loops = _registered_loops(self)
        if loops:
            try:
                _link(self, loops)
                LINKED.append(self.name)
                return
            except Exception:  # noqa: BLE001 - Numba's or llvmlite's internals moved
                LINK_FAILED.append(self.name)
        return optimize(self)

    _optimize_final_module.link_only = True
    CPUCodeLibrary._optimize_final_module = _optimize_final_module
    return True


def _registered_loops(library) -> list:
    """The :func:`loop_kernel` functions that ``library`` defines (not others of the same
    name elsewhere), as LLVM function values."""
    name = getattr(library, "name", None)
    prefixes = tuple(prefix for lib, prefix in _LINK_ONLY if lib == name)
    if not prefixes:
        return []
    try:
        return [f for f in library._final_module.functions
                if not f.is_declaration and f.name.startswith(prefixes)]
    except AttributeError:
        return []


def _link(library, loops) -> None:
    """Inline the direct callees of ``loops`` into them and clean up, nothing more."""
    import llvmlite.binding as llvm

    # everything that may be missing in another Numba or llvmlite first, before the module
    # is touched (a failure then leaves it as Numba made it, for Numba's own optimisation)
    builder = library._codegen._pass_builder(opt=0)
    passes = llvm.create_new_module_pass_manager()
    passes.add_always_inliner_pass()
    passes.add_sroa_pass()
    passes.add_instruction_combine_pass()
    passes.add_simplify_cfg_pass()
    module = library._final_module
    # (the called function is a call instruction's last operand)
    callees = {list(ins.operands)[-1].name for loop in loops for block in loop.blocks
               for ins in block.instructions if ins.opcode == "call"}
    inline = [f for f in module.functions
              if f.name in callees and not f.is_declaration and not _has_noinline(f)]
    for f in inline:
        f.add_function_attribute("alwaysinline")
    passes.run(module, builder)


def _has_noinline(function) -> bool:
    """Whether an LLVM function carries ``noinline`` (which excludes ``alwaysinline``)."""
    names = {a.decode() if isinstance(a, bytes) else str(a) for a in function.attributes}
    return "noinline" in names


LINK_ONLY_INSTALLED = _install_link_only()
