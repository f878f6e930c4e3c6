"""The README's commands as a new user types them: every ``python -m simcore`` line of "One run
from the shell" runs and writes its file (a ``--config`` of the user's own aside), the bad
input it shows gives the error line it shows, and the "From Python" block runs."""

from __future__ import annotations

import contextlib
import io
import re
import shlex
from pathlib import Path

from command_line import call

from simcore.cli import main

README = Path(__file__).resolve().parents[1] / "README.md"
PREFIX = "python -m simcore "


def _section(title: str) -> str:
    text = README.read_text(encoding="utf-8")
    start = text.index(f"## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end >= 0 else None]


def _shell_lines() -> list[str]:
    """The indented command lines of "One run from the shell" (comments dropped)."""
    return [line.strip().split("  #")[0].strip() for line in
            _section("One run from the shell").splitlines()
            if line.startswith("    ") and line.strip().startswith(PREFIX)]


def test_the_shell_commands_of_the_readme_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    lines = [line for line in _shell_lines() if "--config" not in line]
    assert len(lines) >= 3 and any(" zoom " in f" {line} " for line in lines)
    for line in lines:  # in their order: the zoom reads the run written before it
        argv = shlex.split(line[len(PREFIX):])
        code, err = call(main, argv)
        assert code == 0, (line, err)
        assert (tmp_path / argv[argv.index("--out") + 1]).exists(), line


def test_the_bad_input_of_the_readme_gives_the_line_it_shows(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shown = _section("One run from the shell")
    command = re.search(r"^    \$ (python -m simcore .*)$", shown, re.M).group(1)
    error = re.search(r"^    (error: .*)$", shown, re.M).group(1)
    code, lines = call(main, shlex.split(command[len(PREFIX):]))
    assert code == 2 and lines == [error]
    assert not list(tmp_path.iterdir())  # no file


def test_the_python_block_of_the_readme_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    block = re.search(r"```python\n(.*?)```", _section("From Python"), re.S).group(1)
    namespace: dict = {}
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(block, "README.md", "exec"), namespace)  # noqa: S102 (the README's code)
    assert (tmp_path / "run.nc").exists()
    assert namespace["imp"].sizes["impact"] > 0 and float(namespace["zoom"]["F_N"].max()) > 0.0
