"""A command line called in the test's own process, as the tests of the commands use it."""

from __future__ import annotations

import contextlib
import io


def call(main, argv) -> tuple[int, list[str]]:
    """(exit code, stderr lines) of ``main(argv)`` with its output captured; an exception
    that escapes it (a traceback) fails the test."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    return code, [line for line in err.getvalue().splitlines() if line.strip()]
