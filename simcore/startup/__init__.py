"""Start-up machinery: where Numba's cache lives and how it is keyed (:mod:`.numba_cache`), the
cold compile shared with a helper process (:mod:`.parallel_compile`), and every patch on other
libraries' internals for start-up time, behind one switch (:mod:`.patches`,
``BEARINGSIM_STARTUP_PATCHES=0`` turns them off)."""
