"""Figures of a run and of the study: files are written, degenerate inputs are handled."""

import warnings

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
from command_line import call

from analysis import extract_impacts
from analysis.figures import figure_layout, plot_reference, plot_run, plot_study, run_label
from analysis.synthetic import make_run_dataset
from simcore.study.plan import FIGURE_FILES


def _a_study_figure(path) -> bool:
    """Whether a study's figures folder may hold ``path`` (one the study replaces)."""
    from fnmatch import fnmatchcase

    return any(fnmatchcase(path.name, pattern) for pattern in FIGURE_FILES)


@pytest.fixture(scope="module")
def run():
    return make_run_dataset(n_steps=400)


def test_plot_run(run, tmp_path):
    paths = plot_run(run, extract_impacts(run), tmp_path, prefix="case")
    assert [p.name for p in paths] == ["case_lambda.png", "case_orbit.png", "case_slider.png"]
    for p in paths:
        assert p.stat().st_size > 10_000


def test_plot_run_without_journal_or_impacts(run, tmp_path):
    ds = run.drop_vars(["journal_x", "journal_y"])
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        paths = plot_run(ds, None, tmp_path, prefix="x")
    assert [p.name for p in paths] == ["x_lambda.png", "x_slider.png"]
    assert any("orbit" in str(x.message) for x in w)
    quiet = ds.copy()
    quiet["Lambda_N"] = xr.zeros_like(ds["Lambda_N"])
    with pytest.warns(UserWarning, match="orbit"):
        assert plot_run(quiet, None, tmp_path, prefix="q")[0].exists()


def test_run_label(run):
    assert run_label(run) == "g = 400 µm, μ = 0.01, ω0 = 50 rad/s, e_N = 0.9"
    catalogue = run.assign_attrs({"model.bearing": "6205", "model.clearance_class": "C3",
                                  "model.clearance": 1.025e-5})
    assert run_label(catalogue) == "6205 in C3, g = 10.25 µm, μ = 0.01, ω0 = 50 rad/s, e_N = 0.9"


def _summary(shape, fill=None, failed_at=None, extra_axes=None):
    """A summary with the layout of analysis.summary.summarize over a grid of ``shape``, both
    models (``extra_axes``: {name: values} of further swept axes after the four)."""
    values = {"clearance": [2e-5, 1e-4, 4e-4], "mu": [0.0, 0.01, 0.05], "omega0": [25.0, 50.0],
              "e_N": [0.7, 0.9]}
    dims = ("clearance", "mu", "omega0", "e_N") + tuple(extra_axes or ())
    values.update(extra_axes or {})
    shape = tuple(shape) + tuple(len(v) for v in (extra_axes or {}).values())
    coords = {d: values[d][:n] for d, n in zip(dims, shape, strict=True)}
    coords.update(model=np.array([0, 1], "i1"), race=np.array([0, 1], "i1"),
                  kind=np.arange(4, dtype="i1"), level=[100.0, 1000.0], rank=[1, 2, 3],
                  stage=np.arange(3, dtype="i1"))
    rng = np.random.default_rng(0)

    def var(*extra, low=1e2, high=5e3):
        sh = tuple(shape) + tuple(len(coords[e]) for e in extra)
        data = rng.uniform(low, high, sh) if fill is None else np.full(sh, fill)
        return (dims + extra, data)

    ds = xr.Dataset(
        {"peak_force": var("model", "race"), "peak_force_rev_median": var("model", "race"),
         "p_max": var("model", "race"), "p_max_groove": var("model", "race"),
         "startup_peak_force": var("model"),
         "above_per_rev": var("model", "race", "level"), "impacts_per_rev": var("race", "kind"),
         "method_ratio": var("race", low=0.4, high=3.0),
         "static_deflection_ratio": var(low=0.1, high=20.0),
         "L10h": var(low=1e3, high=1e6), "L10rh": var(low=1e3, high=1e6),
         "static_safety_factor": var(low=0.5, high=10.0),
         "iter_max": var("model", "stage"), "failed": (dims + ("model",),
                                                       np.zeros(tuple(shape) + (2,)))},
        coords=coords, attrs={"settle_revolutions": 1.0})
    ds["clearance"].attrs.update(units="m", long_name="radial clearance")
    if failed_at is not None:
        ds["failed"][failed_at] = 1.0
        for name in ds.data_vars:
            if name != "failed":
                ds[name][failed_at] = np.nan
    return ds


PER_MODEL = ["peak_force_outer", "peak_force_inner", "peak_force_rev_median_outer",
             "peak_force_rev_median_inner", "p_max_outer", "p_max_inner", "p_max_groove_outer",
             "p_max_groove_inner", "startup_peak_force", "above_100N_per_rev",
             "above_1000N_per_rev"]
QUANTITIES = ([f"{q}_{m}" for q in PER_MODEL for m in ("nonsmooth", "compliant")]
              + ["method_ratio_outer", "method_ratio_inner", "static_deflection_ratio",
                 "L10h", "L10rh", "static_safety_factor", "impacts_per_rev"])


def test_plot_study_shows_every_point_of_four_swept_parameters(tmp_path):
    ds = _summary((3, 3, 2, 2), failed_at=(0, 1, 0, 1))
    paths = plot_study(ds, tmp_path, part=(0, 8))
    assert paths[0].name == "life_clearance_speed.png"  # part 0 draws the life figure
    paths = paths[1:]
    stems = {p.name.split("_", 1)[1][:-4] for p in paths}
    assert stems <= set(QUANTITIES) and len(stems) == -(-len(QUANTITIES) // 8)
    assert sorted(p.name for p in paths) == sorted(f"{kind}_{q}.png" for q in stems
                                                   for kind in ("study", "pairs"))
    assert all(map(_a_study_figure, paths)), paths
    assert all(p.stat().st_size > 20_000 for p in paths)


def test_plot_study_two_one_and_no_swept_parameters(tmp_path):
    from analysis.figures import _study_quantities

    assert sorted(q.stem for q in _study_quantities(_summary((2, 3, 1, 1)))) == sorted(QUANTITIES)
    paths = plot_study(_summary((2, 3, 1, 1)), tmp_path / "two", part=(1, 8))
    assert len(paths) == len(range(1, len(QUANTITIES), 8))  # every 8th from the second
    assert all(p.name.startswith("study_") for p in paths)
    # p_max and the ratios all missing (older impact tables, no twin): no figures of them
    assert sorted(q.stem for q in _study_quantities(_summary((3, 1, 1, 1), fill=np.nan))) == \
        sorted(q for q in QUANTITIES
               if not q.startswith(("p_max", "method_ratio", "static_", "L10")))
    paths = plot_study(_summary((3, 1, 1, 1), fill=np.nan), tmp_path / "nan", part=(1, 16))
    assert len(paths) == 1 and paths[0].name.startswith("study_")
    paths = plot_study(_summary((1, 1, 1, 1)), tmp_path / "one")
    assert [p.name for p in paths] == ["study_single.png"]
    assert all(map(_a_study_figure, paths))


def test_figure_layout_follows_the_settings():
    ds = _summary((3, 3, 2, 2), extra_axes={"model.cage_stiffness": [1e4, 1e5, 1e6]})
    default = figure_layout(ds)
    assert (default.x, default.y, default.col, default.row) == ("clearance", "mu", "omega0",
                                                                "e_N")
    assert default.fixed == {"model.cage_stiffness": 1e5}  # the middle value
    chosen = figure_layout(ds, ["model.cage_stiffness", "clearance"],
                           figure_fixed={"mu": 0.05}, reference={"omega0": 30.0, "e_N": 0.9})
    assert (chosen.x, chosen.y, chosen.col, chosen.row) == ("model.cage_stiffness", "clearance",
                                                            None, None)
    assert chosen.fixed == {"mu": 0.05, "omega0": 25.0, "e_N": 0.9}
    for bad, match in (((["x_axis"], None), "figure_axes: 'x_axis'"),
                       ((["mu", "mu"], None), "figure_axes"),
                       ((["mu"], {"mu": 0.01}), "figure_axes"),
                       ((None, {"mu": 0.02}), r"figure_fixed.mu: 0.02 is not allowed")):
        with pytest.raises(ValueError, match=match):
            figure_layout(ds, *bad)


def test_a_fifth_axis_is_held_and_any_axis_can_be_drawn(tmp_path):
    ds = _summary((3, 2, 2, 2), extra_axes={"model.cage_stiffness": [1e4, 1e5, 1e6]})
    ds["model.cage_stiffness"].attrs.update(units="N m-1", long_name="cage spring stiffness")
    paths = plot_study(ds, tmp_path, part=(1, 30),
                       figure_axes=["model.cage_stiffness", "clearance", "mu"],
                       figure_fixed={"e_N": 0.7})
    stems = {p.name.split("_", 1)[1] for p in paths}
    assert len(paths) == 2 and len(stems) == 1 and stems.pop()[:-4] in QUANTITIES
    assert sorted(p.name.split("_", 1)[0] for p in paths) == ["pairs", "study"]


def test_a_grid_too_large_to_draw_says_so(tmp_path, monkeypatch):
    ds = _summary((3, 3, 2, 2), extra_axes={"rank_axis": list(np.arange(40.0))})
    from analysis import figures
    from simcore.study.plan import FIGURE_OPTIONS

    paths = plot_study(ds, tmp_path, part=(1, 100), figure_axes=["rank_axis", "clearance"])
    assert figures.MAX_CELLS < 40
    for path in paths:  # the message page (8 in at 100 dpi), not a 40-cell map
        assert plt.imread(path).shape[1] == 800
    # the pages name the settings as the caller sets them: a study's keys, a command's options
    said = []
    monkeypatch.setattr(figures, "_too_large", lambda path, title, message: said.append(message))
    for names, (axes, fixed), other in (
            (None, ("study.figure_axes", "study.figure_fixed"), "--"),
            (FIGURE_OPTIONS, ("--axes", "--fixed"), "study.")):
        said.clear()
        plot_study(ds, tmp_path, part=(1, 100), figure_axes=["rank_axis", "clearance"],
                   **({"names": names} if names else {}))
        assert len(said) == 2  # the heat maps and the pairs figure of one quantity
        assert axes in said[0] and all(fixed in m for m in said)
        assert not any(other in m for m in said), said


def test_plot_reference(run, tmp_path):
    paths = plot_reference(run, extract_impacts(run), tmp_path, settle=0.05)
    # the reference figures job's, with plot_run's under the same prefix
    assert all(map(_a_study_figure, paths + plot_run(run, None, tmp_path, prefix="reference")))
    assert [p.name for p in paths] == [f"reference_{n}.png" for n in (
        "force_angle", "ball_load", "exceedance", "force_speed", "iterations")]
    assert all(p.stat().st_size > 20_000 for p in paths)


def test_study_figures_command_on_a_summary_file(tmp_path):
    """The command reads a summary written to netCDF (integer stage/race/kind coordinates)."""
    from analysis.__main__ import main
    from simcore.io import write_netcdf

    path = write_netcdf(_summary((2, 2, 1, 1)), tmp_path / "summary.nc")
    assert main(["study-figures", str(path)]) == 0
    assert (tmp_path / "figures" / "study_peak_force_outer_nonsmooth.png").exists()
    assert (tmp_path / "figures" / "study_method_ratio_outer.png").exists()
    assert (tmp_path / "figures" / "summary_table.csv").exists()
    assert all(map(_a_study_figure, (tmp_path / "figures").iterdir()))


def test_plot_study_parts_share_the_figures(tmp_path):
    """part=(i, n) draws every n-th quantity: the parts together are the whole set, once."""
    ds = _summary((2, 2, 1, 1))[["peak_force", "method_ratio", "failed"]]  # no life figure
    whole = {p.name for p in plot_study(ds, tmp_path / "all")}
    assert len(whole) == 6
    parts = [{p.name for p in plot_study(ds, tmp_path / f"p{i}", part=(i, 2))} for i in (0, 1)]
    assert parts[0] and parts[1] and not parts[0] & parts[1]
    assert parts[0] | parts[1] == whole
    assert plot_study(_summary((1, 1, 1, 1)), tmp_path / "one", part=(1, 2)) == []
    with pytest.raises(ValueError, match="part"):
        plot_study(ds, tmp_path, part=(2, 2))


def test_life_figure_marks_the_clearance_classes(tmp_path):
    from analysis.figures import plot_life

    ds = _summary((3, 1, 2, 1))
    path = plot_life(ds, tmp_path / "life.png")
    assert path.stat().st_size > 20_000
    with pytest.raises(KeyError):
        plot_life(ds.drop_vars("L10h"), tmp_path / "none.png")


def _bands_drawn(ds, tmp_path, layout=None):
    """The class bands [µm] the life figure of ``ds`` draws (x of each band)."""
    from unittest import mock

    import matplotlib.axes

    from analysis.figures import plot_life

    found = []
    real = matplotlib.axes.Axes.plot

    def spy(self, x, *args, **kwargs):
        if kwargs.get("solid_capstyle") == "butt":  # a class band
            found.append(tuple(np.round(np.asarray(x, dtype=float), 6)))
        return real(self, x, *args, **kwargs)

    with mock.patch.object(matplotlib.axes.Axes, "plot", spy):
        plot_life(ds, tmp_path / "bands.png", layout)
    return found


def test_life_figure_marks_the_classes_of_the_studys_own_bearing(tmp_path):
    """The class bands are those of the bore of the summary's bearing (``model_bearing``):
    for a 6205 (25 mm bore) CN is 5-20 µm of radial internal clearance (ISO 5753-1, bores over
    24 up to 30 mm), a model clearance of 2.5-10 µm; without a bearing, the 6012's 60 mm."""
    ds = _summary((3, 1, 2, 1))
    own = _bands_drawn(ds.assign_attrs(model_bearing="6205"), tmp_path)
    assert (2.5, 10.0) in own and len(own) == 10  # five classes on each of the two panels
    assert set(_bands_drawn(ds, tmp_path)).isdisjoint(own)  # (no bearing named: the 60 mm bore's)


def test_life_figure_of_a_bearing_sweep_marks_the_classes_of_the_bearing_drawn(tmp_path):
    """With a swept bearing the figure holds it at one value (the layout's, else its first):
    the bands are that bearing's, whatever the study's default bearing was."""
    from analysis.figures import figure_layout

    ds = _summary((3, 1, 2, 1)).expand_dims(bearing=2).copy(deep=True)
    ds = ds.assign_coords(bearing=("bearing", np.array([2, 4], "i1"), {
        "flag_values": np.arange(6, dtype="i1"),
        "flag_meanings": "6012-paper 6203 6205 6010 6012 6212"}))
    first = _bands_drawn(ds, tmp_path)
    assert (2.5, 10.0) in first  # the 6205's CN
    held = _bands_drawn(ds, tmp_path, figure_layout(ds, figure_fixed={"bearing": 4}))
    assert held == _bands_drawn(_summary((3, 1, 2, 1)), tmp_path)  # the 6012's 60 mm bore
    # a category is held by its name too (python -m analysis study-figures --fixed bearing=6012)
    for value in ("6012", 4, "4"):
        assert figure_layout(ds, figure_fixed={"bearing": value}).fixed["bearing"] == 4
    with pytest.raises(ValueError, match=r"^study\.figure_fixed\.bearing: '6013' is not allowed; "
                                         r"allowed: one of the grid's values 6205, 6012$"):
        figure_layout(ds, figure_fixed={"bearing": "6013"})


def test_a_class_sweep_gets_the_life_figure_over_its_clearances(tmp_path):
    """A summary whose clearance axis is a clearance class (the clearance of each class a
    coordinate along it) draws the life figure, its points at the classes' clearances."""
    ds = _summary((3, 1, 2, 1))
    clearance = ds["clearance"].values
    ds = ds.rename({"clearance": "clearance_class"}).assign_coords(
        clearance_class=("clearance_class", np.array([1, 2, 3], "i1"), {
            "flag_values": np.array([0, 1, 2, 3, 4], "i1"),
            "flag_meanings": "C2 CN C3 C4 C5"}))
    ds = ds.assign_coords(clearance=("clearance_class", clearance, {"units": "m"}))
    paths = plot_study(ds, tmp_path, part=(0, 8))
    assert paths[0].name == "life_clearance_speed.png"
    fig_lines = _life_lines(ds, tmp_path)
    assert len(fig_lines) == 4  # two speeds, two lives
    assert all(np.array_equal(x, clearance * 1e6) for x in fig_lines)
    # without the clearances there is nothing to draw it over
    assert all(p.name != "life_clearance_speed.png"
               for p in plot_study(ds.drop_vars("clearance"), tmp_path / "b", part=(0, 8)))


def test_the_life_figure_holds_the_axes_it_does_not_draw_at_the_reference_point(tmp_path):
    """Over clearance and speed, the life figure holds the friction (an axis the heat maps
    draw) where the study's reference point is (mu 0.01, the second of two values), not at the
    middle index (the first): its lines are the summary's lives there."""
    from unittest import mock

    import matplotlib.axes

    ds = _summary((3, 2, 2, 1))
    assert not np.allclose(ds["L10h"].sel(mu=0.0), ds["L10h"].sel(mu=0.01))
    drawn = []
    real = matplotlib.axes.Axes.plot

    def spy(self, x, *args, **kwargs):
        if args[1:2] == ("o-",):  # the lives
            drawn.append(np.asarray(args[0], dtype=float))
        return real(self, x, *args, **kwargs)

    reference = {"clearance": 4e-4, "mu": 0.01, "omega0": 50.0, "e_N": 0.7}
    with mock.patch.object(matplotlib.axes.Axes, "plot", spy):
        paths = plot_study(ds, tmp_path, part=(0, 8), reference=reference)
    assert paths[0].name == "life_clearance_speed.png"
    at = ds.sel(mu=0.01, e_N=0.7)
    expected = [at[name].sel(omega0=w).values for name in ("L10h", "L10rh")
                for w in ds["omega0"].values]
    assert len(drawn) == len(expected)
    for got, want in zip(drawn, expected, strict=True):
        np.testing.assert_array_equal(got, want)


def _life_lines(ds, tmp_path):
    """The x data [µm] of every line of lives in the life figure of ``ds``."""
    from unittest import mock

    import matplotlib.axes

    from analysis.figures import plot_life

    xs = []
    real = matplotlib.axes.Axes.plot

    def spy(self, x, *args, **kwargs):
        if args[1:2] == ("o-",):  # the lives (not the class bands)
            xs.append(np.asarray(x, dtype=float))
        return real(self, x, *args, **kwargs)

    with mock.patch.object(matplotlib.axes.Axes, "plot", spy):
        plot_life(ds, tmp_path / "spy.png")
    return xs


def test_study_figures_command_takes_the_layout(tmp_path, capsys):
    from analysis.__main__ import main
    from simcore.io import write_netcdf

    path = write_netcdf(_summary((2, 2, 2, 1))[["peak_force", "failed"]], tmp_path / "s.nc")
    assert main(["study-figures", str(path), "--axes", "omega0", "clearance",
                 "--fixed", "mu=0.01"]) == 0
    printed = capsys.readouterr().out
    assert "study_peak_force_outer_nonsmooth.png" in printed
    assert main(["study-figures", str(path), "--axes", "speed"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --axes: 'speed' is not allowed") and "\n" not in err
    assert main(["study-figures", str(path), "--fixed", "mu=x"]) == 2
    assert capsys.readouterr().err.startswith("error: --fixed mu: 'x' is not allowed")
    (tmp_path / "other").mkdir()  # a summary whose figures folder no call made yet
    other = write_netcdf(_summary((2, 2, 2, 1))[["peak_force", "failed"]],
                         tmp_path / "other" / "s.nc")
    assert main(["study-figures", str(other), "--fixed", "speed=1"]) == 2
    assert capsys.readouterr().err.startswith("error: --fixed speed: 'speed' is not allowed")
    assert main(["study-figures", str(other), "--fixed", "e_N=0.5"]) == 2  # one value, 0.7
    assert capsys.readouterr().err.startswith("error: --fixed e_N: '0.5' is not allowed")
    assert main(["study-figures", str(other), "--axes", "mu", "--fixed", "mu=0.01"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --axes: ['mu'] is not allowed") and "in --fixed" in err, err
    assert not (tmp_path / "other" / "figures").exists()  # refused before the folder is made


def test_study_figures_command_holds_an_axis_at_the_study_reference(tmp_path, monkeypatch):
    """A redraw from the summary file holds an undrawn axis where the study's own figures held
    it: the reference point the summary states, not the middle value."""
    from analysis.__main__ import main
    from analysis.figures import (
        REFERENCE_ATTRIBUTE,
        reference_attribute,
        stored_reference,
    )
    from simcore.io import write_netcdf

    ds = _summary((3, 3, 1, 1))[["peak_force", "failed"]]
    reference = {"clearance": 1e-4, "mu": 0.05, "omega0": 25.0, "e_N": 0.7}
    ds.attrs[REFERENCE_ATTRIBUTE] = reference_attribute(reference, ds)
    path = write_netcdf(ds, tmp_path / "s.nc")
    with xr.open_dataset(path) as back:
        assert stored_reference(back) == reference  # through the file, exactly
    # a category by its name, read back as its code
    swept = ds.expand_dims(bearing=2).copy(deep=True).assign_coords(bearing=(
        "bearing", np.array([2, 4], "i1"), {"flag_values": np.arange(6, dtype="i1"),
                                            "flag_meanings": "6012-paper 6203 6205 6010 6012 "
                                                             "6212"}))
    text = reference_attribute(reference | {"bearing": 4}, swept)
    assert text.endswith(" bearing=6012"), text
    swept.attrs[REFERENCE_ATTRIBUTE] = text
    with xr.open_dataset(write_netcdf(swept, tmp_path / "b.nc")) as back:
        assert stored_reference(back) == reference | {"bearing": 4.0}
    layouts = _record_layouts(monkeypatch)
    assert main(["study-figures", str(path), "--axes", "clearance", "omega0"]) == 0
    assert layouts[-1].fixed == {"mu": 0.05}  # the reference's, not the middle 0.01
    del ds.attrs[REFERENCE_ATTRIBUTE]
    assert stored_reference(ds) is None
    assert main(["study-figures", str(write_netcdf(ds, tmp_path / "t.nc")), "--axes",
                 "clearance", "omega0"]) == 0
    assert layouts[-1].fixed == {"mu": 0.01}  # no reference stated: the middle value


def _record_layouts(monkeypatch) -> list:
    """The layouts the study figures are drawn with, one per call of ``plot_study`` (which
    still draws them)."""
    import analysis.figures

    layouts = []
    real = analysis.figures.plot_study

    def spy(summary, outdir, *args, **kwargs):
        layouts.append(figure_layout(summary, kwargs.get("figure_axes"),
                                     kwargs.get("figure_fixed"), kwargs.get("reference")))
        return real(summary, outdir, *args, **kwargs)

    monkeypatch.setattr(analysis.figures, "plot_study", spy)
    return layouts


def test_a_category_axis_is_labelled_by_its_names(tmp_path):
    from analysis.figures import _fmt_axis

    ds = _summary((3, 1, 1, 1), extra_axes={"damping_law": [0.0, 1.0, 2.0]})
    ds = ds.assign_coords(damping_law=("damping_law", np.arange(3, dtype="i1"), {
        "long_name": "damping law", "flag_values": np.arange(3, dtype="i1"),
        "flag_meanings": "flores hunt_crossley lankarani_nikravesh"}))
    assert _fmt_axis(ds, "damping_law", 1) == "damping_law = hunt_crossley"
    paths = plot_study(ds[["peak_force", "failed"]], tmp_path, part=(0, 4),
                       figure_axes=["damping_law", "clearance"])
    assert paths and all(p.stat().st_size > 10_000 for p in paths)


def test_study_figures_options_given_twice_add_up(tmp_path, monkeypatch):
    """--axes and --fixed given twice take both lists (not the last one alone); an axis held
    twice is refused, naming it, before the figures folder is made."""
    from analysis.__main__ import main
    from simcore.io import write_netcdf

    path = write_netcdf(_summary((2, 2, 2, 2))[["peak_force", "failed"]], tmp_path / "s.nc")
    layouts = _record_layouts(monkeypatch)
    assert main(["study-figures", str(path), "--axes", "clearance", "--axes", "mu",
                 "--fixed", "omega0=25", "--fixed", "e_N=0.9"]) == 0
    assert (layouts[-1].x, layouts[-1].y) == ("clearance", "mu")
    assert layouts[-1].fixed == {"omega0": 25.0, "e_N": 0.9}
    other = tmp_path / "other"
    other.mkdir()
    path = write_netcdf(_summary((2, 2, 2, 2))[["peak_force", "failed"]], other / "s.nc")
    code, lines = call(main, ["study-figures", str(path), "--fixed", "mu=0.01", "mu=0.0"])
    assert code == 2 and len(lines) == 1, lines
    assert lines[0].startswith("error: --fixed: mu given twice"), lines
    assert "one value per axis" in lines[0], lines
    assert not (other / "figures").exists()
