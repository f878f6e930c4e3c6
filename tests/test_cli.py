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


def test_the_bearings_command_lists_every_entry_with_its_balls_and_classes(capsys):
    """``python -m simcore bearings``: one block per catalogue entry, its dimensions and ball set
    as the data file gives them, and the model's clearance of a class from the ISO 5753-1 row
    transcribed here (bore 50-65 mm, C3: 23-43 um radial play, g = a quarter of the sum)."""
    from simcore.model.bearing import catalogue

    assert main(["bearings"]) == 0
    shown = capsys.readouterr().out
    blocks = {block.split(":", 1)[0]: block for block in shown.split("\n")
              if block and not block.startswith(" ")}
    assert list(blocks) == list(catalogue())
    for name, entry in catalogue().items():
        assert f"{entry['d']:g} x {entry['D']:g} x {entry['B']:g} mm" in blocks[name]
        assert f"{entry['Z']} balls of {entry['D_w']:.3f} mm" in blocks[name]
        if entry.get("f_i") is not None:
            grooves = f"grooves f_i {entry['f_i']:g}, f_e {entry['f_e']:g}"
            assert grooves in shown.split(f"{name}:", 1)[1].split("\n")[1]
    block_6012 = shown.split("6012:", 1)[1].split("6212:", 1)[0]
    assert f"C3 {(23 + 43) / 4:.2f}" in block_6012 and "% of its 0.412 kg" in block_6012


def test_a_warning_is_one_line_once(tmp_path):
    """The configuration is checked when it is read and again by the run: its warning (a
    catalogue bearing's ball count overridden) is printed once, as one line."""
    code, lines = call(main, ["run", "--set", "model.bearing=6205", "--set", "model.n_balls=5",
                              "--set", "solver.t_end=0.001", "--quiet",
                              "--out", str(tmp_path / "r.nc")])
    from simcore.model.bearing import catalogue

    assert code == 0
    assert lines == [f"warning: model.n_balls = 5 is given and overrides the "
                     f"{catalogue()['6205']['Z']} of bearing '6205' (catalogue); leave it out to "
                     "take the catalogue's"], lines


def test_a_run_warns_once_of_the_study_settings_it_does_not_read(tmp_path):
    """One run reads no ``study`` setting but ``study.keep``: those that differ from the
    defaults are named in one warning; with ``study.revolutions``, it says that solver.t_end
    sets the run's length and gives the one the revolutions would give."""
    from simcore import load_config
    from simcore.study.plan import run_length

    items = ["study.revolutions=5", "study.models=[compliant]", "solver.t_end=0.001",
             "study.keep=[Lambda_N, iterations, converged, crank_angle]"]
    argv = ["run", *(arg for item in items for arg in ("--set", item)), "--quiet",
            "--out", str(tmp_path / "r.nc")]
    code, lines = call(main, argv)
    assert code == 0 and len(lines) == 1, lines
    assert lines[0].startswith("warning: study: not read by one run"), lines
    assert "study.revolutions = 5" in lines[0] and "study.models = ['compliant']" in lines[0]
    assert "study.keep" not in lines[0] and "study.results_dir" not in lines[0], lines
    study_length = run_length(load_config(overrides=items))
    assert "solver.t_end does (now 0.001 s" in lines[0], lines
    assert lines[0].endswith(f"--set solver.t_end={study_length:g})"), lines
    assert "of this run's settings, which lack the config/config.yaml" in lines[0], lines
    code, lines = call(main, ["run", "--set", "solver.t_end=0.001", "--set",
                              "study.keep=[Lambda_N, iterations, converged, crank_angle]",
                              "--quiet", "--out", str(tmp_path / "k.nc")])
    assert (code, lines) == (0, [])  # study.keep is the run's
