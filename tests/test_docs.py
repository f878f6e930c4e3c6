"""The user's pages name what exists: every Python name, configuration key, command-line
option, script, file and link that the README, config/README.md and docs/ give resolves in
the code as it is (a renamed function or option otherwise leaves a page that sends the reader
nowhere). test_readme.py runs the README's commands; this reads every page."""

from __future__ import annotations

import dataclasses
import importlib
import re
from pathlib import Path

import pytest

import simcore

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", ROOT / "config" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SECTIONS = ("model", "solver", "analysis", "study")
#: the folders of the repository a path on a page starts with
TOP_FOLDERS = ("simcore/", "analysis/", "tests/", "benchmarks/", "docs/", "config/",
               "workflow/", "profiles/", ".ci/")
#: options every argparse command has
BUILT_IN = ("--help",)

_FENCE = re.compile(r"^```[^\n]*\n(.*?)^```", re.S | re.M)
_SPAN = re.compile(r"`([^`]+)`")
_PY_NAME = re.compile(r"^((?:simcore|analysis)(?:\.[A-Za-z_]\w*)+)")
_KEY = re.compile(r"^(model|solver|analysis|study)\.([A-Za-z_]\w*)")
_SCRIPT = re.compile(r"python (benchmarks/\w+\.py)((?:(?!python ).)*)")
_MODULE = re.compile(r"python (-m simcore)\b((?:(?!python ).)*)")
_OPTION = re.compile(r"(?<![\w-])(--[a-z][a-z0-9-]*)")


def _snippets(page: Path):
    """(line, text) of each inline code span (whitespace collapsed: a span may wrap) and each
    line of a fenced block."""
    text = page.read_text(encoding="utf-8")
    for block in _FENCE.finditer(text):
        first = text.count("\n", 0, block.start(1)) + 1
        for i, line in enumerate(block.group(1).splitlines()):
            yield first + i, line
    prose = _FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    for span in _SPAN.finditer(prose):
        yield prose.count("\n", 0, span.start()) + 1, " ".join(span.group(1).split())


def _resolves(dotted: str) -> bool:
    """Whether ``a.b.c`` names a module, or an attribute (a dataclass field, a named tuple's
    field) reached from the longest importable module prefix."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for part in parts[cut:]:
            fields = ({f.name for f in dataclasses.fields(obj)} if dataclasses.is_dataclass(obj)
                      else set(getattr(obj, "_fields", ())))
            if part in fields:
                return True
            if not hasattr(obj, part):
                return False
            obj = getattr(obj, part)
        return True
    return False


def _schema_keys() -> dict[str, set]:
    properties = simcore.load_schema()["properties"]
    return {section: set(properties[section]["properties"]) for section in SECTIONS}


def _references(pages):
    """Every (page, line, text) code snippet of ``pages``."""
    for page in pages:
        for line, text in _snippets(page):
            yield page, line, text


def _where(page: Path, line: int) -> str:
    return f"{page.relative_to(ROOT) if page.is_relative_to(ROOT) else page.name}:{line}: "


def _option_sources(command: str) -> str | None:
    """The source text that declares the options of ``command`` (a benchmark script, whose
    shared options are in benchmarks/_common.py, or ``-m simcore``); None for a script that
    does not exist."""
    if command == "-m simcore":
        return (ROOT / "simcore" / "cli.py").read_text()
    script = ROOT / command
    return (script.read_text() + (ROOT / "benchmarks" / "_common.py").read_text()
            if script.exists() else None)


def _problems(pages, keys: dict[str, set]) -> list[str]:
    """What the code snippets of ``pages`` name that does not exist (``keys``: the schema's
    keys of each section)."""
    problems = []
    for page, line, text in _references(pages):
        where = _where(page, line)
        key = _KEY.match(text)
        name = _PY_NAME.match(text)
        # (`analysis.x` is a key of the analysis section or a name in the analysis package)
        if key and (key.group(1) != "analysis" or key.group(2) in keys["analysis"]
                    or not name):
            if key.group(2) not in keys[key.group(1)] and not text.endswith("unknown key"):
                problems.append(where + f"no configuration key {key.group(0)}")
        elif name and not _resolves(name.group(1)):
            problems.append(where + f"no Python name {name.group(1)}")
        for command in [*_SCRIPT.finditer(text), *_MODULE.finditer(text)]:
            sources = _option_sources(command.group(1))
            if sources is None:
                continue  # (a script that does not exist is reported as a file below)
            problems += [where + f"{command.group(1)} has no option {option}"
                         for option in _OPTION.findall(command.group(2))
                         if option not in BUILT_IN and f'"{option}"' not in sources]
        for token in text.split():
            token = token.strip("\"',.;:()")
            if token.startswith(TOP_FOLDERS) and not re.search(r"[<>{}*~\[$]", token):
                if not (ROOT / token.split("::")[0]).exists():
                    problems.append(where + f"no file {token}")
    return problems


def _broken_links(pages) -> list[str]:
    """The relative links of ``pages`` to files that do not exist."""
    broken = []
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for link in re.finditer(r"\]\(([^)\s]+)\)", text):
            target = link.group(1).split("#", 1)[0]
            if target and "://" not in target and not (page.parent / target).exists():
                line = text.count("\n", 0, link.start()) + 1
                broken.append(_where(page, line) + f"no file {link.group(1)}")
    return broken


def test_the_pages_name_only_what_exists():
    assert _problems(PAGES, _schema_keys()) == []
    assert _broken_links(PAGES) == []


def test_the_pages_are_read_at_all():
    """The scan sees the pages' references: each kind occurs (a pattern that matched nothing
    would make the test above pass on any page)."""
    texts = [text for _, _, text in _references(PAGES)]
    assert sum(bool(_SCRIPT.search(t)) for t in texts) > 20
    assert sum(bool(_MODULE.search(t)) for t in texts) > 5
    assert sum(bool(_KEY.match(t)) for t in texts) > 100
    assert sum(bool(_PY_NAME.match(t)) for t in texts) > 50
    assert sum(t.startswith(TOP_FOLDERS) for t in texts) > 20


@pytest.mark.parametrize("snippet, expected", [
    ("`python benchmarks/twin_steps.py --revolutions 5 --no-such-option`",
     "benchmarks/twin_steps.py has no option --no-such-option"),
    ("`python -m simcore run --help --no-such-option`",
     "-m simcore has no option --no-such-option"),
    ("```sh\npython -m simcore run --no-such-option\n```",
     "-m simcore has no option --no-such-option"),
    ("`solver.no_such_key`", "no configuration key solver.no_such_key"),
    ("`analysis.no_such_key`", "no Python name analysis.no_such_key"),
    ("`analysis.summary.no_such_function`", "no Python name analysis.summary.no_such_function"),
    ("`simcore.study.plan.no_such_function(x)`",
     "no Python name simcore.study.plan.no_such_function"),
    ("`benchmarks/no_such_script.py`", "no file benchmarks/no_such_script.py"),
    ("`python benchmarks/no_such.py --revolutions 5`", "no file benchmarks/no_such.py"),
    ("[the model](no_such_page.md)", "no file no_such_page.md"),
])
def test_a_wrong_reference_is_found(tmp_path, snippet, expected):
    """Each check finds a wrong reference of its kind."""
    page = tmp_path / "page.md"
    page.write_text(f"Some text\n{snippet}\nmore text\n")
    found = _problems([page], _schema_keys()) + _broken_links([page])
    assert [f"page.md:{3 if snippet.startswith('```') else 2}: {expected}"] == found
