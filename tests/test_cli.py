"""The command line's own help: every example that ``python -m simcore run --help`` prints
runs (shortened to a few milliseconds of simulated time) and writes its file."""

from __future__ import annotations

import shlex

import pytest
from command_line import call

from simcore.cli import RUN_EXAMPLES, main


def _run_examples() -> list[list[str]]:
    """The argument lists of the examples ``run --help`` shows."""
    prefix = "python -m simcore "
    assert all(line.startswith(prefix) for line in RUN_EXAMPLES)
    return [shlex.split(line[len(prefix):]) for line in RUN_EXAMPLES]


def test_the_help_shows_its_examples(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    shown = capsys.readouterr().out
    assert all(line in shown for line in RUN_EXAMPLES) and len(RUN_EXAMPLES) >= 3


@pytest.mark.parametrize("example", _run_examples(), ids=lambda argv: " ".join(argv[1:-2]))
def test_every_example_of_the_run_help_runs(example, tmp_path):
    argv = list(example)
    out = tmp_path / "example.nc"
    argv[argv.index("--out") + 1] = str(out)
    code, lines = call(main, [*argv, "--set", "solver.t_end=0.003", "--quiet"])
    assert code == 0 and out.exists(), lines
