"""Start-up machinery: where Numba's cache lives and how it is keyed (:mod:`.numba_cache`), and
the cold compile shared with a helper process (:mod:`.parallel_compile`)."""
