"""Compliant zoom on a nonsmooth run: restart from the run's state, force histories, the CLI
verb, and the impact table's F_max_zoom."""

import warnings

import numpy as np
import pytest

import analysis
import simcore
from analysis.zoom import add_zoom_forces
from simcore.cli import main
from simcore.config import ConfigError, load_config
from simcore.io import generalized
from simcore.model import ReleaseStop, SolverSettings


@pytest.fixture(scope="module")
def run_ds():
    return simcore.run(load_config(overrides=["solver.t_end=0.004"]))


@pytest.fixture(scope="module")
def first_impact(run_ds):
    lam = run_ds["Lambda_N"].values
    k = np.unravel_index(int(np.argmax(lam)), lam.shape)
    return float(run_ds.time[k[0]]), int(run_ds.contact[k[1]])


def test_zoom_restarts_from_the_state_before_the_impact(run_ds, first_impact):
    time, contact = first_impact
    z = simcore.zoom(run_ds, time, window=1e-3, dt=1e-6)
    i = int(np.searchsorted(run_ds.time.values, time)) - 1
    assert z.attrs["zoom_start_time"] == pytest.approx(float(run_ds.time[i]))
    assert z.attrs["contact_model"] == "compliant"
    zq, rq = generalized(z), generalized(run_ds)  # q and v from position/angle, velocities
    np.testing.assert_array_equal(zq["q"].isel(time=0).values, rq["q"].isel(time=i).values)
    np.testing.assert_array_equal(zq["v"].isel(time=0).values, rq["v"].isel(time=i).values)
    F = z["F_N"].sel(contact=contact).values
    assert F.max() > 0.0 and F[0] == 0.0
    # the bearing then carries the load: its contacts stay closed, the window bounds the zoom
    assert float(z.time[-1]) == pytest.approx(float(z.time[0]) + 1e-3)
    assert int(z["converged"].min()) == 1
    # same mechanism as the run: the slider does not jump at the restart
    assert abs(float(z.slider_x[1]) - float(run_ds.slider_x[i])) < 1e-5


def test_zoom_time_outside_the_run_is_refused(run_ds):
    with pytest.raises(ConfigError, match=r"^time: 0\.5 is not allowed"):
        simcore.zoom(run_ds, 0.5)
    with pytest.raises(ConfigError, match=r"^time: 0\.0 is not allowed"):
        simcore.zoom(run_ds, 0.0)


def test_a_zoom_is_checked_like_a_run_before_any_work(run_ds, first_impact, tmp_path, capsys):
    """A zoom whose arrays would not fit is refused by the memory check, naming the window,
    with no file; a zoom asked for another contact model is refused, naming the key."""
    run_file = tmp_path / "run.nc"
    simcore.write_netcdf(run_ds, run_file)
    out = tmp_path / "z.nc"
    time, _ = first_impact
    assert main(["zoom", str(run_file), "--time", str(time), "--window", "1", "--dt", "1e-9",
                 "--set", "solver.adaptive=false", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --window: 1") and "max_memory_gb" in err and "\n" not in err
    assert not out.exists()
    with pytest.raises(ConfigError, match=r"^model\.contact_model: 'nonsmooth' is not allowed"):
        simcore.zoom(run_ds, time, overrides=["model.contact_model=nonsmooth",
                                              "solver.adaptive=false"])


def test_a_zoom_refuses_a_set_of_what_its_options_set(run_ds, first_impact, tmp_path):
    """--set of a zoom: a key path through a setting is refused naming it; a setting that
    --window or --dt sets is refused naming --set and the option to use (simcore.zoom: the
    parameter); a bad --window or --dt is still named as such."""
    from command_line import call

    run_file = tmp_path / "run.nc"
    simcore.write_netcdf(run_ds, run_file)
    zoom = ["zoom", str(run_file), "--time", str(first_impact[0]), "--out",
            str(tmp_path / "z.nc")]
    for extra, start, words in (
            (["--set", "model.mu.x=1"], "error: model.mu.x: not allowed", ["model.mu=VALUE"]),
            (["--set", "solver.t_end=2000"], "error: --set: solver.t_end=2000 is not allowed",
             ["allowed: --window"]),
            (["--set", "solver.dt=1e-4", "--set", "solver.adaptive=false"],
             "error: --set: solver.dt=1e-4 is not allowed", ["allowed: --dt"]),
            (["--set", "solver.output_dt=1e-5"], "error: --set: solver.output_dt=1e-5",
             ["allowed: --dt"]),
            (["--window", "2000"], "error: --window: 2000", ["(0, 1000]"]),
            (["--dt", "1e-4", "--set", "solver.adaptive=false"], "error: --dt: 0.0001",
             ["solver.on_unresolved_dt"])):
        code, lines = call(main, [*zoom, *extra])
        assert code == 2 and len(lines) == 1 and lines[0].startswith(start), (extra, lines)
        assert all(word in lines[0] for word in words), (extra, lines)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.nc"]
    with pytest.raises(ConfigError, match=r"^overrides: solver\.t_end=1 is not allowed in a "
                                          r"zoom; allowed: window"):
        simcore.zoom(run_ds, first_impact[0], overrides=["solver.t_end=1"])


def test_cli_zoom(run_ds, first_impact, tmp_path, capsys):
    run_file = tmp_path / "run.nc"
    simcore.write_netcdf(run_ds, run_file)
    out = tmp_path / "z.nc"
    assert main(["zoom", str(run_file), "--time", "0.5", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --time: 0.5 is not allowed") and "\n" not in err
    assert not out.exists()
    assert main(["zoom", str(run_file), "--time", "0.001", "--set", "model.damping_law=x",
                 "--out", str(out)]) == 2
    assert "model.damping_law" in capsys.readouterr().err and not out.exists()
    time, _ = first_impact
    assert main(["zoom", str(run_file), "--time", str(time), "--window", "5e-4", "--quiet",
                 "--out", str(out)]) == 0
    import xarray as xr

    with xr.open_dataset(out) as z:
        assert float(z["F_N"].max()) > 0.0
        assert z["F_N"].attrs["units"] == "N"


def _expected_zoom_rows(table, zoom_top, settle_time):
    """The rows the summary reads, written as a plain walk (independent of analysis.zoom): the
    largest force of each race in the steady window, then the next largest, zoom_top in all;
    plus the largest of the start-up."""
    F, race, t = (table[name].values for name in ("F_max", "race", "time"))
    steady = [i for i in range(F.size) if np.isfinite(F[i]) and t[i] > settle_time]
    startup = [i for i in range(F.size) if np.isfinite(F[i]) and t[i] <= settle_time]
    heads = []
    for r in (0, 1):
        mine = [i for i in steady if race[i] == r]
        if mine:
            heads.append(max(mine, key=lambda i: (F[i], -i)))
    chosen = sorted(heads, key=lambda i: -F[i])[:zoom_top]
    for i in sorted(steady, key=lambda i: (-F[i], i)):
        if len(chosen) < zoom_top and i not in chosen:
            chosen.append(i)
    if startup:
        chosen.append(max(startup, key=lambda i: (F[i], -i)))
    return chosen


def test_zooms_go_where_the_summary_reads(run_ds):
    from analysis.zoom import zoom_rows

    imp = analysis.extract_impacts(run_ds)
    settle_time = 0.002
    rows = zoom_rows(imp, 3, settle_time)
    assert list(rows) == _expected_zoom_rows(imp, 3, settle_time)
    # the impacts that give each race's steady peak and the start-up peak are among them
    F, race, t = imp["F_max"].values, imp["race"].values, imp["time"].values
    for r in (0, 1):
        mine = np.flatnonzero((race == r) & (t > settle_time) & np.isfinite(F))
        assert mine[np.argmax(F[mine])] in rows
    early = np.flatnonzero((t <= settle_time) & np.isfinite(F))
    assert early[np.argmax(F[early])] == rows[-1]
    assert zoom_rows(imp, 0, settle_time).size == 0
    # a synthetic table: one race only, ties broken by order
    import xarray as xr

    table = xr.Dataset({"F_max": ("impact", [5.0, np.nan, 7.0, 7.0, 1.0]),
                        "race": ("impact", [1, 1, 1, 1, 1]),
                        "time": ("impact", [0.5, 0.6, 0.7, 0.8, 0.1])})
    np.testing.assert_array_equal(zoom_rows(table, 2, 0.2), [2, 3, 4])


def test_impact_table_gets_zoom_forces(run_ds):
    imp = analysis.extract_impacts(run_ds)
    table = add_zoom_forces(run_ds, imp, zoom_top=2, settle_time=0.002)
    zoomed = np.isfinite(table["dt_zoom"].values)
    assert set(np.flatnonzero(zoomed)) == set(_expected_zoom_rows(imp, 2, 0.002))
    assert table.attrs["n_zoomed"] == 3
    F_zoom = table["F_max_zoom"].values[zoomed]
    assert np.all(np.isnan(F_zoom) | (F_zoom > 0.0))
    ct = table["contact_time_zoom"].values[zoomed]
    assert np.all(np.isnan(ct) | (ct > 0.0))
    assert table["F_max_zoom"].attrs["units"] == "N"
    assert table["contact_time_zoom"].attrs["units"] == "s"
    off = add_zoom_forces(run_ds, imp, zoom_top=0)
    assert np.all(np.isnan(off["F_max_zoom"].values))
    with pytest.raises(ValueError, match="analysis.zoom_top"):
        add_zoom_forces(run_ds, imp, zoom_top=-1)
    with pytest.raises(ValueError, match="analysis.method_tol"):
        add_zoom_forces(run_ds, imp, zoom_top=1, method_tol=0.0)


@pytest.fixture(scope="module")
def steel_run():
    """Steel, constant drive: isolated single-ball impacts (Hertz contacts of a few us, a third
    of a step) and the first pinch of a loaded ball at 1.5 ms."""
    return simcore.run(load_config(overrides=["solver.t_end=0.008", "model.drive=constant",
                                              "model.youngs_modulus=2.1e11"]))


def test_a_zoom_that_contradicts_the_paper_flags_the_impact_and_an_isolated_one_does_not(
        steel_run):
    """The paper's force is the Flores force of one ball of effective mass m_eff. An isolated
    impact of a single ball (kind simple, m_eff within twice the ball's mass, contact far
    shorter than a step) is that case, and its compliant zoom agrees within method_tol. A
    pinch (a ball squeezed between the races by kilograms of crank and rod) is not: the
    mechanism keeps loading the ball through a contact that lasts ten steps, and the zoom
    disagrees."""
    from analysis import FLAG, KIND

    imp = analysis.extract_impacts(steel_run)
    kind, F = imp["kind"].values, imp["F_max"].values
    m_ball = float(steel_run.attrs["model.ball_mass"])
    isolated = np.flatnonzero((kind == KIND["simple"]) & np.isfinite(F)
                              & (imp["m_eff"].values < 2 * m_ball)
                              & (imp["contact_time_steps"].values < 1.0))
    pinch = np.flatnonzero((kind == KIND["pinch"]) & np.isfinite(F))
    chosen = [int(isolated[np.argmax(F[isolated])]), int(pinch[np.argmax(F[pinch])])]
    table = add_zoom_forces(steel_run, imp.isel(impact=chosen), zoom_top=2, method_tol=0.2)
    ratio = table["F_max"].values / table["F_max_zoom"].values
    bit = FLAG["method_disagrees"]
    flags, trusted = table["flags"].values, table["trusted"].values
    assert abs(ratio[0] - 1.0) <= 0.2 and not flags[0] & bit and trusted[0] == 1
    assert abs(ratio[1] - 1.0) > 0.2 and flags[1] & bit and trusted[1] == 0
    assert table.attrs["n_method_disagrees"] == 1
    assert table.attrs["n_trusted"] == int(np.count_nonzero(trusted))
    assert "method_disagrees" in table["flags"].attrs["flag_meanings"].split()
    # the pinch's two rows (the ball on either race) read the same episode of the ball
    pair = np.flatnonzero((kind == KIND["pinch"]) & np.isclose(imp["time"].values,
                                                               float(imp["time"][chosen[1]])))
    both = add_zoom_forces(steel_run, imp.isel(impact=pair), zoom_top=len(pair))
    assert len(pair) == 2 and both["F_max_zoom"].values[0] == both["F_max_zoom"].values[1]
    # a looser tolerance that covers the pinch's ratio leaves its row unflagged by the method
    loose = add_zoom_forces(steel_run, imp.isel(impact=chosen), zoom_top=2,
                            method_tol=abs(ratio[1] - 1.0) * 1.01)
    assert not np.any(loose["flags"].values & bit)


def test_a_zoom_that_flagged_a_step_gives_no_verdict(steel_run, monkeypatch):
    """The pinch whose zoom contradicts the paper (above) keeps its F_max_zoom but gets no
    ``method_disagrees`` when its zoom flagged one of its own steps (not converged, energy
    created, an integrity check): an unconverged reference decides nothing."""
    from analysis import FLAG, KIND
    from analysis import zoom as module

    imp = analysis.extract_impacts(steel_run)
    pinch = np.flatnonzero((imp["kind"].values == KIND["pinch"]) & np.isfinite(imp["F_max"]))
    row = int(pinch[np.argmax(imp["F_max"].values[pinch])])
    honest = add_zoom_forces(steel_run, imp.isel(impact=[row]), zoom_top=1, method_tol=0.2)
    assert honest["flags"].values[0] & FLAG["method_disagrees"]
    zoom_numbers = module._zoom_numbers

    def flagged(*args, **kwargs):
        out, steps, smallest = zoom_numbers(*args, **kwargs)
        return {r: (force, time, 1) for r, (force, time, _) in out.items()}, steps, smallest

    monkeypatch.setattr(module, "_zoom_numbers", flagged)
    table = add_zoom_forces(steel_run, imp.isel(impact=[row]), zoom_top=1, method_tol=0.2)
    assert table["zoom_flagged"].values[0] == 1
    assert table["F_max_zoom"].values[0] == honest["F_max_zoom"].values[0]
    assert not table["flags"].values[0] & FLAG["method_disagrees"]
    assert table.attrs["n_method_disagrees"] == 0


def test_adaptive_zoom_of_an_impact_matches_the_fine_fixed_zoom(steel_run):
    """The study's adaptive zoom (largest step and output interval t_Hertz / 5) of an isolated
    single-ball impact and of a pinch gives F_max_zoom within 1 % of a fixed zoom at t_Hertz /
    160, and records what it did: the largest step allowed (dt_zoom, 32 times the fine step), a
    smaller step taken where the contact needed it, its steps and the setting."""
    from analysis import KIND
    from analysis.zoom import ADAPTIVE_STEPS_PER_CONTACT

    imp = analysis.extract_impacts(steel_run)
    kind, F = imp["kind"].values, imp["F_max"].values
    m_ball = float(steel_run.attrs["model.ball_mass"])
    isolated = np.flatnonzero((kind == KIND["simple"]) & np.isfinite(F)
                              & (imp["m_eff"].values < 2 * m_ball))
    pinch = np.flatnonzero((kind == KIND["pinch"]) & np.isfinite(F))
    chosen = imp.isel(impact=[int(isolated[np.argmax(F[isolated])]),
                              int(pinch[np.argmax(F[pinch])])])
    adaptive = add_zoom_forces(steel_run, chosen, zoom_top=2, adaptive=True)
    fine = add_zoom_forces(steel_run, chosen, zoom_top=2, steps_per_contact=160,
                           adaptive=False)
    F_adaptive, F_fine = adaptive["F_max_zoom"].values, fine["F_max_zoom"].values
    assert np.all(np.isfinite(F_adaptive)) and np.all(F_fine > 0.0)
    np.testing.assert_allclose(F_adaptive, F_fine, rtol=0.01)
    np.testing.assert_allclose(adaptive["dt_zoom"].values, fine["dt_zoom"].values * 160
                               / ADAPTIVE_STEPS_PER_CONTACT, rtol=1e-12)
    assert np.all(adaptive["dt_zoom_smallest"].values < adaptive["dt_zoom"].values)
    np.testing.assert_array_equal(fine["dt_zoom_smallest"].values, fine["dt_zoom"].values)
    assert adaptive.attrs["zoom_adaptive"] == 1 and fine.attrs["zoom_adaptive"] == 0
    assert adaptive.attrs["zoom_steps_per_contact"] == ADAPTIVE_STEPS_PER_CONTACT
    assert 0 < adaptive.attrs["n_zoom_steps"] < fine.attrs["n_zoom_steps"]
    assert adaptive["dt_zoom"].attrs["comment"].startswith("largest step allowed")
    assert fine["dt_zoom"].attrs["comment"].startswith("time step of the compliant zoom")
    assert int(adaptive["zoom_flagged"].max()) == 0


def test_simulation_stops_once_the_contacts_have_opened_again():
    """ReleaseStop: a ball thrown at a plane (no gravity) stops the run soon after it
    leaves the plane, long before the requested end."""
    from simcore.model.mechanism import ball_on_plane

    model = ball_on_plane(radius=0.01, mass=0.0327, height=0.01 + 1e-6, e_N=1.0, gravity=0.0,
                          speed=(0.0, -1.0))
    settings = SolverSettings(1e-7, 1e-2, contact_model="compliant", chunk=100)
    traj = model.simulate(settings, release=ReleaseStop())
    assert traj.F_N.max() > 0.0 and traj.F_N[-1, 0] == 0.0
    assert traj.time[-1] < 2e-4
    assert traj.v[-1, 1] > 0.99


def test_contact_time_of_a_sampled_hertz_pulse_is_found_between_samples():
    """An undamped Hertz contact: the indentation leaves and returns to zero linearly in time,
    the force goes as its 3/2 power. Sampled at dt = T/40 (the zoom's step), the duration is
    found to a small fraction of a step, where counting samples errs by up to a step."""
    from analysis.zoom import _first_episode

    T, dt = 1.7e-4, 1.7e-4 / 40
    for shift in (0.0, 0.13, 0.5, 0.91):  # where the contact starts within a step
        t = np.arange(-5, 60) * dt
        delta = np.sin(np.pi * (t - shift * dt) / T)
        force = np.where((t - shift * dt > 0) & (t - shift * dt < T), delta, 0.0) ** 1.5
        assert _first_episode(force, dt) == pytest.approx(T, rel=2e-3)
    assert _first_episode(np.zeros(5), dt) == 0.0
    assert _first_episode(np.array([0.0, 2.0, 0.0, 0.0]), dt) == pytest.approx(dt)  # one sample
    assert np.isnan(_first_episode(np.array([0.0, 1.0, 2.0]), dt))


def test_zoom_step_follows_the_hertz_contact_time(run_ds):
    """dt = t_Hertz / N: a 100 times stiffer material shortens a Hertz contact by 100^(2/5)
    (t ~ K^(-2/5)), a faster impact by (v ratio)^(1/5); the run's own step caps it."""
    from analysis.zoom import STEPS_PER_CONTACT, zoom_step
    from simcore.config.limits import hertz_contact_time
    from simcore.study.zoom import zoom_config

    soft = zoom_config(run_ds)["model"]
    stiff = zoom_config(run_ds, overrides=["model.youngs_modulus=2.1e11"])["model"]
    assert soft["youngs_modulus"] == 2.1e9
    h_soft = zoom_step(soft, 1.0, [0.5], STEPS_PER_CONTACT)
    h_stiff = zoom_step(stiff, 1.0, [0.5], STEPS_PER_CONTACT)
    assert h_soft / h_stiff == pytest.approx(100.0 ** 0.4, rel=1e-12)
    assert h_soft == pytest.approx(hertz_contact_time(soft) / STEPS_PER_CONTACT)
    fast = 20.0 * abs(soft["omega0"]) * soft["crank_length"]  # 20 times the pin speed
    assert zoom_step(soft, 1.0, [fast], 1) == pytest.approx(
        hertz_contact_time(soft) / 20.0 ** 0.2, rel=1e-12)
    assert zoom_step(soft, 1e-7, [0.5], 1) == 1e-7


def test_impact_table_records_the_zoom_step(run_ds):
    from analysis.zoom import ADAPTIVE_STEPS_PER_CONTACT, STEPS_PER_CONTACT
    from simcore.config.limits import hertz_contact_time

    imp = analysis.extract_impacts(run_ds)
    table = add_zoom_forces(run_ds, imp, zoom_top=1, adaptive=False)
    zoomed = np.isfinite(table["F_max_zoom"].values)
    t_hertz = hertz_contact_time(simcore.validate_config(
        {"model": {k.split(".", 1)[1]: v for k, v in run_ds.attrs.items()
                   if k.startswith("model.")}})["model"])
    assert table["dt_zoom"].attrs["units"] == "s"
    np.testing.assert_allclose(table["dt_zoom"].values[zoomed], t_hertz / STEPS_PER_CONTACT)
    assert np.all(np.isnan(table["dt_zoom"].values[~zoomed]))
    assert table.attrs["zoom_steps_per_contact"] == STEPS_PER_CONTACT
    assert table.attrs["zoom_adaptive"] == 0
    # adaptive (the default): the largest step allowed, a fifth of the contact time
    adaptive = add_zoom_forces(run_ds, imp, zoom_top=1)
    assert adaptive.attrs["zoom_adaptive"] == 1
    np.testing.assert_allclose(adaptive["dt_zoom"].values[zoomed],
                               t_hertz / ADAPTIVE_STEPS_PER_CONTACT)


def _ball_episode_peak(F_ball, F_contact):
    """The definition of F_max_zoom written as a plain walk over the samples (independent of
    analysis.zoom): from the impact contact's first force, walk back and forth while the ball
    carries a force; the largest force on that stretch, NaN if it is the last sample."""
    n = len(F_ball)
    # a force at the first sample alone is the run's state at the solver's tolerance
    first = next((i for i in range(n) if F_contact[i] > 0.0
                  and (i > 0 or n == 1 or F_contact[1] > 0.0)), None)
    lo, hi = 0, n - 1
    if first is not None:
        lo = first
        while lo > 0 and F_ball[lo - 1] > 0.0:
            lo -= 1
        hi = first
        while hi + 1 < n and F_ball[hi + 1] > 0.0:
            hi += 1
    best = max(range(lo, hi + 1), key=lambda i: (F_ball[i], -i))
    return np.nan if best == n - 1 else F_ball[best]


def test_episode_peak_takes_the_impact_of_the_ball_only():
    from analysis.zoom import _episode_peak, _first_episode, _struck

    contact = np.array([0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    other = np.array([0.0, 0.5, 0.0, 0.0, 3.0, 0.0, 9.0, 9.5, 0.0])  # the ball's other contact
    ball = np.maximum(contact, other)
    # the episode runs from sample 1 (the other contact closed first) to 5: peak 3.0; the
    # later, larger contact (9.5) is another episode
    assert _episode_peak(ball, contact) == 3.0 == _ball_episode_peak(ball, contact)
    rising = np.array([0.0, 1.0, 2.0, 3.0])
    assert np.isnan(_episode_peak(rising, rising))
    never = np.zeros(4)  # the impact's contact never closes: the ball's whole zoom
    assert _episode_peak(np.array([0.0, 2.0, 1.0, 0.0]), never) == 2.0
    # a touch at the first sample alone (the run's state) is not the impact
    touch = np.array([1e-14, 0.0, 0.0, 5.0, 7.0, 0.0])
    assert _episode_peak(touch, _struck(touch)) == 7.0 == _ball_episode_peak(touch, touch)
    assert _first_episode(_struck(touch), 1.0) > 1.0
    held = np.array([1.0, 2.0, 0.0])  # closed at the first two samples: kept
    np.testing.assert_array_equal(_struck(held), held)


@pytest.mark.parametrize("adaptive", [False, True])
def test_zoom_stops_when_the_balls_are_free_and_reports_the_full_window_numbers(
        run_ds, monkeypatch, adaptive):
    """The early stop on the impacts' balls: each number of the table equals the one read
    from a zoom over the whole window (until_released=False), by the independent walk above,
    and the stopped zooms are shorter. An adaptive zoom's samples are read at the output
    instants (its force masked where the contact is open there, its contact time from the
    indentation), as the table reads them."""
    import simcore.study.zoom
    from analysis.zoom import _at_sample_instants, _first_episode

    imp = analysis.extract_impacts(run_ds)
    calls = []
    zoom_trajectory = simcore.study.zoom.zoom_trajectory

    def recording(run, time, **kw):
        out = zoom_trajectory(run, time, **kw)
        calls.append((time, kw, out[0].time.size))
        return out

    monkeypatch.setattr(simcore.study.zoom, "zoom_trajectory", recording)
    table = add_zoom_forces(run_ds, imp, zoom_top=3, adaptive=adaptive)
    monkeypatch.undo()
    stopped = 0
    for time, kw, n_rows in calls:
        with warnings.catch_warnings():  # (the zooms of the table flag what they find)
            warnings.simplefilter("ignore", RuntimeWarning)
            traj, model, _, zcfg = simcore.study.zoom.zoom_trajectory(
                run_ds, time, window=kw["window"], dt=kw["dt"], until_released=False,
                overrides=kw["overrides"], adaptive=adaptive)
        stopped += n_rows < traj.time.size
        F, pulses = traj.F_N, traj.F_N
        if adaptive:
            F, indentation = _at_sample_instants(traj, model, zcfg)
            pulses = indentation ** 1.5
        for row in np.flatnonzero(np.isclose(table["time"].values, time, rtol=0, atol=0)):
            if not np.isfinite(table["dt_zoom"].values[row]):
                continue
            contact = int(table["contact"].values[row])
            ball = run_ds["ball"].values == int(table["ball"].values[row])
            ball = np.concatenate([ball, np.zeros(F.shape[1] - ball.size, dtype=bool)])
            expected = _ball_episode_peak(F[:, ball].max(axis=1), F[:, contact])
            got = float(table["F_max_zoom"].values[row])
            assert got == expected or (np.isnan(got) and np.isnan(expected))
            Fc = pulses[:, contact].copy()
            if Fc[0] > 0.0 and Fc[1] == 0.0:
                Fc[0] = 0.0
            t_full = _first_episode(Fc, kw["dt"])
            got = float(table["contact_time_zoom"].values[row])
            assert got == t_full or (np.isnan(got) and np.isnan(t_full))
    assert stopped >= 1


def test_watch_contacts_waits_for_the_onset_of_its_group():
    """A group's episode starts at its onset contact: a ball thrown at a plane with its only
    contact watched stops after the rebound; the same run watching for an onset that never
    comes (an empty onset) runs to its end. A wrong shape is refused naming the key."""
    from simcore.model.mechanism import ball_on_plane

    model = ball_on_plane(radius=0.01, mass=0.0327, height=0.01 + 1e-6, e_N=1.0, gravity=0.0,
                          speed=(0.0, -1.0))
    settings = SolverSettings(1e-7, 5e-4, contact_model="compliant", chunk=100)
    traj = model.simulate(settings, release=ReleaseStop([True], [True]))
    assert traj.F_N.max() > 0.0 and traj.F_N[-1, 0] == 0.0 and traj.time[-1] < 2e-4
    whole = model.simulate(settings, release=ReleaseStop([True], [False]))
    assert whole.time[-1] == pytest.approx(5e-4)
    np.testing.assert_array_equal(whole.F_N[:len(traj.time)], traj.F_N)
    with pytest.raises(ValueError, match="^watch_contacts"):
        model.simulate(settings, release=ReleaseStop([True, False]))


def test_a_pinch_reads_the_squeeze_not_an_earlier_touch():
    """A ball touches the inner race lightly, leaves it, then is squeezed between both races:
    both rows of the pinch read the squeeze (the larger of the ball's two contacts over the
    episode where both carry force); the inner contact alone would read the touch."""
    from analysis.zoom import _episode_peak, _pinch_onset

    inner = np.array([0.0, 0.0, 2.0, 1.0, 0.0, 0.0, 3.0, 8.0, 9.0, 4.0, 0.0, 0.0])
    outer = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 9.5, 8.5, 3.0, 0.0, 0.0])
    pair = np.stack([inner, outer], axis=1)
    ball = pair.max(axis=1)
    assert _episode_peak(ball, _pinch_onset(pair)) == 9.5
    assert _episode_peak(ball, inner) == 2.0  # the touch, as a single-ball row would read it
    # never together: the first force on either contact
    apart = np.stack([inner, np.zeros_like(inner)], axis=1)
    assert _episode_peak(apart.max(axis=1), _pinch_onset(apart)) == 2.0


def test_a_pinch_watch_starts_where_both_races_carry_the_ball():
    """A ball struck on one race, free for a sample, then pinched between both: watched from its
    struck contact the episode ends at the short release; watched as a pinch (both races as
    onset) it starts at the squeeze and ends when the ball is free again."""
    from simcore.model.driver import _ReleaseWatch

    F = np.array([[0, 0], [5, 0], [0, 0], [3, 4], [2, 1], [0, 0], [0, 0]], dtype=float)
    struck = _ReleaseWatch([[True, True]], [[True, False]], 2)
    pinch = _ReleaseWatch([[True, True]], [[True, True]], 2)
    assert struck.released(F, 0, 3)
    assert not pinch.released(F, 0, 3)
    assert not pinch.released(F, 3, 5)  # squeezed on rows 3 and 4
    assert pinch.released(F, 5, 7)
    assert list(pinch.onset_row) == [3]


@pytest.fixture(scope="module")
def loaded_run():
    """Steel at 20 µm and 100 rad/s, constant drive: balls in persistent loaded contact."""
    return simcore.run(load_config(overrides=[
        "model.clearance=2e-5", "model.omega0=100", "model.e_N=0.9", "model.drive=constant",
        "model.youngs_modulus=2.1e11", "solver.t_end=0.012"]))


def test_a_zoom_from_the_rigid_state_overshoots_on_a_loaded_ball(loaded_run):
    """Why a loaded ball's zoom gives no verdict: restarted from the rigid state, its contacts
    start undeformed under their load, and its force overshoots as under a suddenly applied
    load. Started 2, 6 or 10 ms earlier, the contacts have taken their deflection by the time
    of the impact: those agree with each other within 10 %, far below the restart's force."""
    from analysis import extract_impacts
    from analysis.zoom import loaded_at_start, zoom_rows

    table = extract_impacts(loaded_run)
    row = int(zoom_rows(table, 1, settle_time=0.006)[0])
    assert loaded_at_start(loaded_run, table, [row], 0.2)[0]
    t = float(table["time"][row])
    ball = np.flatnonzero(loaded_run["ball"].values == int(table["ball"][row]))
    peaks = {}
    for lead in (0.0, 2e-3, 6e-3, 1e-2):
        z = simcore.zoom(loaded_run, t - lead if lead else t, window=lead + 1e-3, dt=4e-6,
                         until_released=False)
        F = z["F_N"].values[:, ball].max(axis=1)
        near = (z.time.values >= t - 1e-4) & (z.time.values <= t + 1e-3)
        peaks[lead] = F[near].max()
    settled = [peaks[lead] for lead in (2e-3, 6e-3, 1e-2)]
    assert max(settled) < 1.1 * min(settled)
    assert peaks[0.0] > 1.4 * max(settled)


def test_a_loaded_ball_is_not_zoomed_and_gets_no_verdict(loaded_run):
    """The zoom rows whose ball is loaded at the zoom's start are marked, left without
    ``F_max_zoom`` and without ``method_disagrees``; with ``loaded="zoom"`` they are zoomed, and
    still get no verdict."""
    from analysis import extract_impacts
    from analysis.zoom import add_zoom_forces, zoom_rows

    table = extract_impacts(loaded_run)
    rows = zoom_rows(table, 3, settle_time=0.006)
    skipped = add_zoom_forces(loaded_run, table, zoom_top=3, settle_time=0.006)
    zoomed = add_zoom_forces(loaded_run, table, zoom_top=3, settle_time=0.006, loaded="zoom")
    marked = skipped["zoom_loaded_start"].values[rows] == 1
    assert marked.all() and skipped.attrs["n_zoom_loaded_start"] == rows.size
    assert np.isnan(skipped["F_max_zoom"].values[rows]).all()
    assert skipped.attrs["n_zoomed"] == 0
    assert np.isfinite(zoomed["F_max_zoom"].values[rows]).all()
    for out in (skipped, zoomed):
        assert out.attrs["n_method_disagrees"] == 0
        np.testing.assert_array_equal(out["flags"].values, table["flags"].values)
